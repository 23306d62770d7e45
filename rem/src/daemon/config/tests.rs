use super::*;

#[test]
fn only_this_builds_protocol_or_a_newer_one_is_announced() {
    assert_eq!(announced_protocol(None).unwrap(), PROTOCOL);
    assert_eq!(
        announced_protocol(Some(PROTOCOL + 1)).unwrap(),
        PROTOCOL + 1
    );
    let e = announced_protocol(Some(PROTOCOL - 1))
        .unwrap_err()
        .to_string();
    assert!(e.contains("announces no older one"), "{e}");
}

#[test]
fn the_default_address_is_loopback_on_the_default_port() {
    let addr: std::net::SocketAddr = DEFAULT_ADDR.parse().unwrap();
    assert_eq!(
        addr,
        DaemonSettings::new("h", Secret::new("s").unwrap()).listen
    );
    assert_eq!(addr.port(), DEFAULT_PORT);
}

#[test]
fn file_fills_what_flags_leave_out() {
    let dir = tempfile::tempdir().unwrap();
    let secret = dir.path().join("secret");
    std::fs::write(&secret, "s3cret\n").unwrap();
    private(&secret);
    let cfg = dir.path().join("remd.toml");
    std::fs::write(
        &cfg,
        format!(
            "name = \"filehost\"\nlisten = \"127.0.0.1:9000\"\nsecret_file = {:?}\n\
             allow = [\"/bin/true\", \"/usr/bin/sunray:worker|controller\"]\n\
             allow_any_args = true\n\
             probe_ms = 100\nsuspect_ms = 600\n[limits]\nspawn_count = 8\n\
             mailbox_bytes = \"2M\"\n",
            secret
        ),
    )
    .unwrap();
    let args = options([
        "remd",
        "--config",
        cfg.to_str().unwrap(),
        "--name",
        "flaghost",
    ]);
    let s = DaemonSettings::from_options(args).unwrap();
    assert_eq!(s.name, "flaghost");
    assert_eq!(s.listen, "127.0.0.1:9000".parse().unwrap());
    assert_eq!(s.policy.programs.len(), 2);
    assert_eq!(s.policy.programs[0].path, PathBuf::from("/bin/true"));
    assert_eq!(
        s.policy.programs[1].first_args,
        Some(vec!["worker".to_string(), "controller".to_string()])
    );
    assert_eq!((s.limits.spawn_count, s.limits.mailbox_bytes), (8, 2 << 20));
    assert_eq!(s.swim.probe_period, Duration::from_millis(100));
    assert_eq!(s.swim.suspect_after, Duration::from_millis(600));
    assert!(s.secret.matches(b"s3cret"));
}

#[test]
fn rejects_bad_settings() {
    let dir = tempfile::tempdir().unwrap();
    let secret = dir.path().join("secret");
    std::fs::write(&secret, "x").unwrap();
    private(&secret);
    let sf = secret.to_str().unwrap();
    let bad_name = options(["remd", "--name", "a/b", "--secret-file", sf]);
    assert!(DaemonSettings::from_options(bad_name).is_err());
    let relative = options([
        "remd",
        "--name",
        "a",
        "--secret-file",
        sf,
        "--allow",
        "bin/x",
    ]);
    assert!(DaemonSettings::from_options(relative).is_err());
    let cfg = dir.path().join("bad.toml");
    std::fs::write(&cfg, "nmae = 1\n").unwrap();
    let unknown = options([
        "remd",
        "--config",
        cfg.to_str().unwrap(),
        "--secret-file",
        sf,
    ]);
    assert!(DaemonSettings::from_options(unknown).is_err());
    let bad_limit = options(["remd", "--secret-file", sf, "--limit", "spawn_count=0"]);
    assert!(DaemonSettings::from_options(bad_limit).is_err());
    // A secret every user can read, or a client key, is refused.
    let open = dir.path().join("open");
    std::fs::write(&open, "x").unwrap();
    std::fs::set_permissions(&open, std::os::unix::fs::PermissionsExt::from_mode(0o644)).unwrap();
    let args = options(["remd", "--secret-file", open.to_str().unwrap()]);
    let err = DaemonSettings::from_options(args).unwrap_err().to_string();
    assert!(err.contains("readable by every user"), "{err}");
    let key = dir.path().join("client-key");
    std::fs::write(
        &key,
        Secret::new("x").unwrap().client_key_line("u").unwrap(),
    )
    .unwrap();
    private(&key);
    let args = options(["remd", "--secret-file", key.to_str().unwrap()]);
    assert!(DaemonSettings::from_options(args).is_err());
}

#[test]
fn a_program_without_an_argument_rule_needs_allow_any_args() {
    let dir = tempfile::tempdir().unwrap();
    let secret = dir.path().join("secret");
    std::fs::write(&secret, "x").unwrap();
    private(&secret);
    let sf = secret.to_str().unwrap();
    let base = ["remd", "--secret-file", sf, "--allow", "/usr/bin/sunray"];
    let err = DaemonSettings::from_options(options(base))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("--allow /usr/bin/sunray: no argument rule")
            && err.contains("/usr/bin/sunray:worker|controller")
            && err.contains("--allow-any-args"),
        "{err}"
    );
    let ruled = [
        "remd",
        "--secret-file",
        sf,
        "--allow",
        "/usr/bin/sunray:worker",
    ];
    assert!(DaemonSettings::from_options(options(ruled)).is_ok());
    let said = [
        "remd",
        "--secret-file",
        sf,
        "--allow",
        "/bin/true",
        "--allow-any-args",
    ];
    let s = DaemonSettings::from_options(options(said)).unwrap();
    assert_eq!(s.policy.programs[0].first_args, None);
}

#[test]
fn the_shipped_config_file_parses() {
    let text = include_str!("../../../../deploy/remd.toml");
    let file: DaemonOptions = toml::from_str(text).unwrap();
    assert_eq!(file.allow, ["/usr/local/bin/sunray:worker|controller"]);
    // It listens off loopback, so it ships with TLS, not `insecure`.
    assert!(file.tls_cert.is_some() && file.tls_key.is_some());
    assert_eq!(file.tls_domain.as_deref(), Some("rem.cluster"));
    let mut limits = Limits::default();
    for pair in &file.limits {
        limits.set_pair(pair).unwrap();
    }
    assert_eq!(limits, Limits::default(), "the file shows the defaults");
}

/// Options as the `remd` binary would give them for these flags (the few the tests use).
fn options<const N: usize>(argv: [&str; N]) -> DaemonOptions {
    let mut o = DaemonOptions::default();
    let mut it = argv.into_iter().skip(1);
    while let Some(flag) = it.next() {
        if flag == "--allow-any-args" {
            o.allow_any_args = Some(true);
            continue;
        }
        let value = it.next().unwrap();
        match flag {
            "--config" => o.config = Some(value.into()),
            "--name" => o.name = Some(value.into()),
            "--secret-file" => o.secret_file = Some(value.into()),
            "--allow" => o.allow.push(value.into()),
            "--limit" => o.limits.push(value.into()),
            _ => panic!("no such flag in the tests: {flag}"),
        }
    }
    o
}

fn private(path: &Path) {
    std::fs::set_permissions(path, std::os::unix::fs::PermissionsExt::from_mode(0o600)).unwrap();
}
