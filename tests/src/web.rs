//! remd's web view from a test: its HTTP API through a blocking client that hands back every
//! status (no redirects followed), logins, server-sent events, and the page itself in a real
//! headless Chromium driven through ChromeDriver ([`Page`]).

use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// How a request proves itself.
#[derive(Clone, Debug)]
pub enum Auth {
    /// No credential.
    None,
    /// `Authorization: Bearer TOKEN`.
    Bearer(String),
    /// The session cookie, and the CSRF token to send with it (if any).
    Cookie { id: String, csrf: Option<String> },
}

/// A response: status, headers we look at, body.
#[derive(Debug)]
pub struct Reply {
    pub status: u16,
    pub location: Option<String>,
    pub set_cookie: Option<String>,
    pub content_type: Option<String>,
    pub csp: Option<String>,
    pub body: Vec<u8>,
}

impl Reply {
    pub fn text(&self) -> String {
        String::from_utf8_lossy(&self.body).to_string()
    }

    pub fn json(&self) -> serde_json::Value {
        serde_json::from_slice(&self.body)
            .unwrap_or_else(|e| panic!("not JSON ({e}): {}", self.text()))
    }
}

/// A client of one daemon's web view.
pub struct WebClient {
    base: String,
    agent: ureq::Agent,
}

impl WebClient {
    /// A client of the page at `base` (`http://127.0.0.1:PORT/`).
    pub fn new(base: &str) -> WebClient {
        let agent: ureq::Agent = ureq::Agent::config_builder()
            .http_status_as_error(false)
            .max_redirects(0)
            .timeout_global(Some(Duration::from_secs(20)))
            .build()
            .into();
        WebClient {
            base: base.trim_end_matches('/').to_string(),
            agent,
        }
    }

    fn url(&self, path: &str) -> String {
        format!("{}{path}", self.base)
    }

    fn reply(mut res: ureq::http::Response<ureq::Body>) -> Reply {
        let header = |name: &str| {
            res.headers()
                .get(name)
                .and_then(|v| v.to_str().ok())
                .map(str::to_string)
        };
        let (location, set_cookie, content_type, csp) = (
            header("location"),
            header("set-cookie"),
            header("content-type"),
            header("content-security-policy"),
        );
        Reply {
            status: res.status().as_u16(),
            location,
            set_cookie,
            content_type,
            csp,
            body: res
                .body_mut()
                .with_config()
                .limit(64 << 20)
                .read_to_vec()
                .unwrap(),
        }
    }

    fn with_auth<B>(req: ureq::RequestBuilder<B>, auth: &Auth) -> ureq::RequestBuilder<B> {
        match auth {
            Auth::None => req,
            Auth::Bearer(t) => req.header("Authorization", format!("Bearer {t}")),
            Auth::Cookie { id, csrf } => {
                let req = req.header("Cookie", format!("rem_session={id}"));
                match csrf {
                    Some(c) => req.header("X-CSRF-Token", c),
                    None => req,
                }
            }
        }
    }

    pub fn get(&self, path: &str, auth: &Auth) -> Reply {
        let req = WebClient::with_auth(self.agent.get(self.url(path)), auth);
        WebClient::reply(req.call().unwrap())
    }

    pub fn post(&self, path: &str, auth: &Auth) -> Reply {
        let req = WebClient::with_auth(self.agent.post(self.url(path)), auth);
        WebClient::reply(req.send_empty().unwrap())
    }

    /// `POST /login` with `token` (and an `Origin` header, when given).
    pub fn post_login(&self, token: &str, origin: Option<&str>) -> Reply {
        let mut req = self.agent.post(self.url("/login"));
        if let Some(o) = origin {
            req = req.header("Origin", o);
        }
        WebClient::reply(req.send_form([("token", token)]).unwrap())
    }

    /// Logs in with `token`: the session cookie and its CSRF token.
    pub fn login(&self, token: &str) -> Auth {
        let r = self.post_login(token, None);
        assert_eq!(r.status, 303, "{}", r.text());
        let cookie = r.set_cookie.expect("a session cookie");
        let id = cookie
            .split(';')
            .next()
            .and_then(|kv| kv.strip_prefix("rem_session="))
            .unwrap()
            .to_string();
        let auth = Auth::Cookie {
            id: id.clone(),
            csrf: None,
        };
        let session = self.get("/api/session", &auth).json();
        let csrf = session["csrf"].as_str().unwrap().to_string();
        Auth::Cookie {
            id,
            csrf: Some(csrf),
        }
    }

    /// Opens `/api/stream` (with `?job=ID`): the status, and the events as they come.
    pub fn stream(&self, query: &str, auth: &Auth) -> (u16, EventReader) {
        let req = self.agent.get(self.url(&format!("/api/stream{query}")));
        let req = WebClient::with_auth(req, auth)
            .config()
            .timeout_global(None)
            .build();
        let res = req.call().unwrap();
        let status = res.status().as_u16();
        let reader = BufReader::new(
            Box::new(res.into_body().into_reader()) as Box<dyn std::io::Read + Send>
        );
        (status, EventReader { reader })
    }

    /// Polls `GET path` until `want` holds of its JSON (bounded): that JSON.
    pub fn wait_json(
        &self,
        path: &str,
        auth: &Auth,
        what: &str,
        timeout: Duration,
        want: impl Fn(&serde_json::Value) -> bool,
    ) -> serde_json::Value {
        let end = Instant::now() + timeout;
        loop {
            let r = self.get(path, auth);
            if r.status == 200 && want(&r.json()) {
                return r.json();
            }
            assert!(
                Instant::now() < end,
                "{what}: still {} {}",
                r.status,
                r.text()
            );
            std::thread::sleep(Duration::from_millis(200));
        }
    }
}

/// Server-sent events read off an open stream.
pub struct EventReader {
    reader: BufReader<Box<dyn std::io::Read + Send>>,
}

impl EventReader {
    /// The next event: its name and data (`None` when the stream ends).
    pub fn next_event(&mut self) -> Option<(String, String)> {
        let (mut name, mut data) = (String::new(), String::new());
        loop {
            let mut line = String::new();
            if self.reader.read_line(&mut line).ok()? == 0 {
                return None;
            }
            let line = line.trim_end_matches(['\r', '\n']);
            if line.is_empty() {
                if !data.is_empty() {
                    return Some((name, data));
                }
                continue;
            }
            if let Some(v) = line.strip_prefix("event:") {
                name = v.trim().to_string();
            } else if let Some(v) = line.strip_prefix("data:") {
                data.push_str(v.trim_start());
            }
        }
    }
}

/// Debian's Chromium (or `SUNRAY_CHROMIUM`), if this machine has one.
pub fn chromium() -> Option<PathBuf> {
    if let Ok(p) = std::env::var("SUNRAY_CHROMIUM") {
        return Some(PathBuf::from(p));
    }
    find_in_path(&["chromium", "chromium-browser", "google-chrome"])
}

/// Where the browser tests leave their screenshots (`WEB_SCREENSHOTS`, else
/// `target/web-screenshots`).
pub fn screenshot_dir() -> PathBuf {
    let dir = std::env::var_os("WEB_SCREENSHOTS")
        .map(PathBuf::from)
        .unwrap_or_else(|| super::bins::workspace().join("target/web-screenshots"));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// ChromeDriver (Debian's `chromium-driver`, or `SUNRAY_CHROMEDRIVER`), if this machine has it.
pub fn chromedriver() -> Option<PathBuf> {
    if let Ok(p) = std::env::var("SUNRAY_CHROMEDRIVER") {
        return Some(PathBuf::from(p));
    }
    find_in_path(&["chromedriver"])
}

fn find_in_path(names: &[&str]) -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    names
        .iter()
        .flat_map(|name| std::env::split_paths(&path).map(move |d| d.join(name)))
        .find(|p| p.is_file())
}

/// One window of a headless Chromium, driven through ChromeDriver (WebDriver); both end
/// when it is dropped.
pub struct Page {
    rt: tokio::runtime::Runtime,
    client: Option<fantoccini::Client>,
    driver: std::process::Child,
}

impl Page {
    /// Starts ChromeDriver and Chromium at `browser`, and opens `url` in a 1400x1300 window.
    pub fn open(browser: PathBuf, url: &str) -> Page {
        let driver_bin = chromedriver().expect("chromedriver (apt-get install chromium-driver)");
        let port = std::net::TcpListener::bind("127.0.0.1:0")
            .unwrap()
            .local_addr()
            .unwrap()
            .port();
        let driver = std::process::Command::new(driver_bin)
            .arg(format!("--port={port}"))
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap();
        let mut caps = serde_json::Map::new();
        caps.insert(
            "goog:chromeOptions".into(),
            serde_json::json!({
                "binary": browser,
                // Root in a container: Chromium's sandbox needs namespaces it may not have.
                "args": ["--headless=new", "--no-sandbox", "--disable-dev-shm-usage",
                         "--window-size=1400,1300", "--hide-scrollbars"],
            }),
        );
        let client = rt.block_on(async {
            let end = Instant::now() + Duration::from_secs(30);
            loop {
                let connector = hyper_util::client::legacy::connect::HttpConnector::new();
                let made = fantoccini::ClientBuilder::new(connector)
                    .capabilities(caps.clone())
                    .connect(&format!("http://127.0.0.1:{port}"))
                    .await;
                match made {
                    Ok(c) => break c,
                    Err(e) => {
                        assert!(Instant::now() < end, "no WebDriver session: {e}");
                        tokio::time::sleep(Duration::from_millis(200)).await;
                    }
                }
            }
        });
        rt.block_on(client.goto(url)).unwrap();
        Page {
            rt,
            client: Some(client),
            driver,
        }
    }

    fn client(&self) -> &fantoccini::Client {
        self.client.as_ref().unwrap()
    }

    /// The value of JavaScript expression `expr`.
    pub fn eval(&self, expr: &str) -> serde_json::Value {
        self.try_eval(expr).unwrap()
    }

    fn try_eval(&self, expr: &str) -> Result<serde_json::Value, String> {
        self.rt
            .block_on(self.client().execute(&format!("return ({expr});"), vec![]))
            .map_err(|e| e.to_string())
    }

    /// Waits (bounded) until `expr` is true in the page (a script error counts as not yet);
    /// on a timeout, leaves a screenshot `failed-WHAT.png` of what the page showed.
    pub fn wait_for(&self, expr: &str, what: &str, timeout: Duration) {
        let end = Instant::now() + timeout;
        loop {
            let now = self.try_eval(expr);
            if now == Ok(serde_json::Value::Bool(true)) {
                return;
            }
            if Instant::now() > end {
                let shot = self.screenshot(&format!("failed-{}.png", what.replace(' ', "-")));
                let url = self.rt.block_on(self.client().current_url());
                panic!(
                    "the page never showed {what} ({expr}): last {now:?}; at {url:?}; see {}",
                    shot.display()
                );
            }
            std::thread::sleep(Duration::from_millis(200));
        }
    }

    /// The element `selector` finds.
    fn find(&self, selector: &str) -> fantoccini::elements::Element {
        self.rt
            .block_on(self.client().find(fantoccini::Locator::Css(selector)))
            .unwrap_or_else(|e| panic!("no {selector} on the page: {e}"))
    }

    /// Logs in through the page's form, as a person would: types `token`, presses the button.
    pub fn login(&self, token: &str) {
        let field = self.find("#token");
        self.rt.block_on(field.send_keys(token)).unwrap();
        self.click("#login-submit");
        self.wait_for(
            "!document.getElementById('app').hidden",
            "the farm after the login",
            Duration::from_secs(20),
        );
    }

    /// Clicks the element `selector` finds.
    pub fn click(&self, selector: &str) {
        let e = self.find(selector);
        self.rt.block_on(e.click()).unwrap();
    }

    /// Saves a PNG of the window to `name` in [`screenshot_dir`]; its path.
    pub fn screenshot(&self, name: &str) -> PathBuf {
        let png = self.rt.block_on(self.client().screenshot()).unwrap();
        let path = screenshot_dir().join(name);
        std::fs::write(&path, png).unwrap();
        eprintln!("screenshot: {}", path.display());
        path
    }
}

impl Drop for Page {
    fn drop(&mut self) {
        if let Some(c) = self.client.take() {
            let _ = self.rt.block_on(c.close());
        }
        let _ = self.driver.kill();
        let _ = self.driver.wait();
    }
}
