//! A model of a quarter of a million triangles on the cluster: shipped to the hosts once,
//! then found in every host's cache.

use super::*;

/// tetra at size 9 (262,144 triangles, a 26 MB model: more than one REM message) on the six
/// hosts with no flags but the image size: identical to `sunray render`; a second job of the
/// same scene finds it on every host and ships nothing.
pub fn a_quarter_million_triangles_on_six_hosts(cluster: &ComposeCluster) {
    let scene = spd_tetra(9);
    let flags = ["--resolution", "96x64"];
    let want = reference(cluster.dir.path(), &scene, &flags).0;
    // The hosts whose first worker built (and so kept) the BVH.
    let mut built = Vec::new();
    for (run, first) in [("tetra9-a", true), ("tetra9-b", false)] {
        let png = format!("/out/{run}.png");
        let json = format!("/out/{run}.json");
        let o = output(&mut cluster.exec(
            "ws1",
            // In this process: the job's end waits for every host's figures (a farm job's
            // statistics are those of the moment its image was stored).
            &submit_args(&[
                "--hosts",
                "6",
                "--in-process",
                "-q",
                flags[0],
                flags[1],
                "/scenes/tetra9.nff",
                "-o",
                &png,
                "--stats-json",
                &json,
            ]),
        ));
        assert!(o.status.success(), "{run}: submit failed");
        let png = cluster.out(&format!("{run}.png"));
        let got = std::fs::read(&png).unwrap_or_else(|e| panic!("{}: {e}", png.display()));
        assert!(
            got == want,
            "{run}: the cluster's image of tetra9 differs from sunray render"
        );
        let stats = read_json(&cluster.out(&format!("{run}.json")));
        assert_eq!(stats["totals"]["primitives"], 262_144, "{stats}");
        let figures = scene_figures(&stats);
        assert_eq!(figures.len(), 6, "{figures:?}");
        if first {
            // The submitting host had the model; every other host whose worker had its scene
            // by the moment the image was stored fetched it (how many got that far is timing:
            // 4 of 5 before session 38, 3 of 5 once rendering and reading took less).
            let ready = scene_ready_hosts(&stats);
            let fetched: Vec<_> = figures.iter().filter(|f| f.1 > 0).collect();
            assert!(!fetched.is_empty(), "{run}: no host fetched: {figures:?}");
            assert!(
                figures
                    .iter()
                    .all(|f| f.0 == "ws1" || f.1 > 0 || !ready.contains(&f.0)),
                "{run}: a host had its scene ({ready:?}) without fetching it: {figures:?}"
            );
            // Lines were rendered, so at least one worker built the BVH.
            built = prepared_hosts(&stats);
            assert!(!built.is_empty(), "{stats}");
        } else {
            // Nothing shipped, and every host whose worker had its scene by the moment the
            // image was stored found it in its cache (a host still starting then says
            // neither: its timeline has no scene_ready).
            let ready = scene_ready_hosts(&stats);
            assert!(!ready.is_empty(), "{run}: no worker had its scene: {stats}");
            assert!(
                figures
                    .iter()
                    .all(|f| f.1 == 0 && (f.2 || !ready.contains(&f.0))),
                "{run}: the hosts that had the scene ({ready:?}) had it cached: {figures:?}"
            );
            assert_eq!(stats["scene_bytes_sent"], 0, "{run}");
            let accel = accel_figures(&stats);
            assert!(
                accel.iter().all(|a| a.1 || !built.contains(&a.0)),
                "{run}: every host kept the BVH it built ({built:?}): {accel:?}"
            );
        }
    }
}
