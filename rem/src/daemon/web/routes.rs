//! The web view's HTTP handlers (see the table in [`super`]).

use std::convert::Infallible;
use std::sync::Arc;
use std::time::Duration;

use axum::extract::{DefaultBodyLimit, Path, Query, State};
use axum::http::{header, HeaderMap, HeaderValue, StatusCode};
use axum::response::sse::{Event, KeepAlive, Sse};
use axum::response::{IntoResponse, Redirect, Response};
use axum::routing::{get, post};
use axum::{Form, Json, Router};
use serde::Deserialize;
use serde_json::json;
use tokio::sync::mpsc;

use super::farm_view::{FarmView, JobRow};
use super::job_view;
use super::login::{self, Proof};
use super::WebState;
use crate::auth::identity::Identity;

/// Largest request body (a login form).
const MAX_BODY: usize = 8 * 1024;

/// How long a request for the jobs waits for the sampler to list them.
const JOBS_WAIT: Duration = Duration::from_secs(4);

const PAGE: &str = include_str!("assets/index.html");
const SCRIPT: &str = include_str!("assets/app.js");
const STYLE: &str = include_str!("assets/app.css");

pub(super) fn router(state: WebState) -> Router {
    Router::new()
        .route(
            "/",
            get(|| async { asset("text/html; charset=utf-8", PAGE) }),
        )
        .route(
            "/app.js",
            get(|| async { asset("text/javascript", SCRIPT) }),
        )
        .route("/app.css", get(|| async { asset("text/css", STYLE) }))
        .route("/login", post(log_in))
        .route("/logout", post(log_out))
        .route("/api/session", get(session))
        .route("/api/hosts", get(hosts))
        .route("/api/jobs", get(jobs))
        .route("/api/jobs/{id}", get(job))
        .route("/api/jobs/{id}/image.png", get(image))
        .route("/api/jobs/{id}/view/{view}", get(view_image))
        .route("/api/jobs/{id}/cancel", post(cancel))
        .route("/api/stream", get(stream))
        .layer(DefaultBodyLimit::max(MAX_BODY))
        .layer(axum::middleware::map_response(harden))
        .with_state(state)
}

/// Headers on every response: no framing, no sniffing, no referrer to other sites, scripts and styles from
/// this origin only, nothing cached.
async fn harden(mut res: Response) -> Response {
    let h = res.headers_mut();
    let set = [
        (
            header::CONTENT_SECURITY_POLICY,
            "default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self'; \
             connect-src 'self'; form-action 'self'; frame-ancestors 'none'; base-uri 'none'",
        ),
        (header::X_FRAME_OPTIONS, "DENY"),
        (header::X_CONTENT_TYPE_OPTIONS, "nosniff"),
        // `same-origin`, not `no-referrer`: with that, browsers send `Origin: null` on the login
        // form's POST, which the same-origin check must refuse.
        (header::REFERRER_POLICY, "same-origin"),
        (header::CACHE_CONTROL, "no-store"),
    ];
    for (name, value) in set {
        h.insert(name, HeaderValue::from_static(value));
    }
    res
}

fn asset(kind: &'static str, body: &'static str) -> Response {
    ([(header::CONTENT_TYPE, kind)], body).into_response()
}

/// An error as the API gives it: a status and `{"error": "..."}`.
struct ApiError(StatusCode, String);

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        (self.0, Json(json!({ "error": self.1 }))).into_response()
    }
}

impl From<crate::Error> for ApiError {
    fn from(e: crate::Error) -> Self {
        use crate::Error as E;
        let status = match &e {
            E::Refused(_) => StatusCode::FORBIDDEN,
            E::NotFound(_) => StatusCode::NOT_FOUND,
            E::Invalid(_) => StatusCode::BAD_REQUEST,
            E::Limit(_) => StatusCode::TOO_MANY_REQUESTS,
            E::Unreachable { .. } | E::ShuttingDown => StatusCode::SERVICE_UNAVAILABLE,
            _ => StatusCode::INTERNAL_SERVER_ERROR,
        };
        ApiError(status, e.to_string())
    }
}

type ApiResult<T> = Result<T, ApiError>;

fn unauthorized() -> ApiError {
    ApiError(
        StatusCode::UNAUTHORIZED,
        "log in first: a login token (`rem web-token`) in the form, or `Authorization: Bearer TOKEN`"
            .into(),
    )
}

/// The caller's proof, or 401.
fn proof(state: &WebState, headers: &HeaderMap) -> ApiResult<Proof> {
    login::prove(headers, &state.tokens, &state.sessions).ok_or_else(unauthorized)
}

#[derive(Deserialize)]
struct LoginForm {
    token: String,
}

/// Trades a login token for a session cookie; back to the page either way (a failed login
/// says so on it).
async fn log_in(
    State(state): State<WebState>,
    headers: HeaderMap,
    Form(form): Form<LoginForm>,
) -> Response {
    // A login posted from another site's page (login CSRF) is refused.
    if !same_origin(&headers) {
        return ApiError(StatusCode::FORBIDDEN, "cross-origin login refused".into())
            .into_response();
    }
    let Some(who) = state.tokens.identify(&form.token) else {
        tracing::info!("web view: a login with a wrong token");
        return Redirect::to("/?login=failed").into_response();
    };
    match state.sessions.open(who) {
        Ok((id, _)) => (
            [(header::SET_COOKIE, login::set_cookie(&id))],
            Redirect::to("/"),
        )
            .into_response(),
        Err(e) => ApiError::from(e).into_response(),
    }
}

/// True unless the request says it comes from a page of another origin.
fn same_origin(headers: &HeaderMap) -> bool {
    let Some(origin) = headers.get(header::ORIGIN) else {
        return true;
    };
    let host = headers.get(header::HOST).and_then(|h| h.to_str().ok());
    match (origin.to_str().ok(), host) {
        (Some(o), Some(h)) => o == format!("http://{h}") || o == format!("https://{h}"),
        _ => false,
    }
}

async fn log_out(State(state): State<WebState>, headers: HeaderMap) -> ApiResult<Response> {
    let proof = proof(&state, &headers)?;
    if !proof.may_change(&headers) {
        return Err(csrf_refused());
    }
    if let Proof::Cookie { id, .. } = &proof {
        state.sessions.close(id);
    }
    Ok((
        [(header::SET_COOKIE, login::set_cookie(""))],
        StatusCode::NO_CONTENT,
    )
        .into_response())
}

fn csrf_refused() -> ApiError {
    ApiError(
        StatusCode::FORBIDDEN,
        format!("missing or wrong {} header", login::CSRF_HEADER),
    )
}

async fn session(
    State(state): State<WebState>,
    headers: HeaderMap,
) -> ApiResult<Json<serde_json::Value>> {
    let proof = proof(&state, &headers)?;
    let csrf = match &proof {
        Proof::Cookie { session, .. } => Some(session.csrf.clone()),
        Proof::Bearer(_) => None,
    };
    let who = proof.who();
    Ok(Json(json!({
        "user": who.user, "admin": who.admin, "csrf": csrf, "host": state.daemon.name,
    })))
}

async fn hosts(
    State(state): State<WebState>,
    headers: HeaderMap,
) -> ApiResult<Json<serde_json::Value>> {
    proof(&state, &headers)?;
    let view = state.view.borrow().clone();
    Ok(Json(
        json!({ "unix_ms": view.unix_ms, "hosts": view.hosts }),
    ))
}

/// The jobs `who` may see, from the sampler (which starts listing them when asked).
async fn jobs_for(state: &WebState, who: &Identity) -> ApiResult<Vec<JobRow>> {
    state.demand.touch();
    let mut rx = state.view.clone();
    let wait = async {
        loop {
            let now = rx.borrow_and_update().jobs_for(who);
            if let Some(jobs) = now {
                return Some(jobs);
            }
            if rx.changed().await.is_err() {
                return None;
            }
        }
    };
    match tokio::time::timeout(JOBS_WAIT, wait).await {
        Ok(Some(jobs)) => Ok(jobs),
        _ => Err(ApiError(
            StatusCode::SERVICE_UNAVAILABLE,
            "the jobs could not be listed in time; try again".into(),
        )),
    }
}

async fn jobs(
    State(state): State<WebState>,
    headers: HeaderMap,
) -> ApiResult<Json<serde_json::Value>> {
    let proof = proof(&state, &headers)?;
    let jobs = jobs_for(&state, proof.who()).await?;
    Ok(Json(json!({ "jobs": jobs })))
}

/// Job `id` as `who` may see it, or 404 (also for another user's job: its existence is not
/// told).
async fn row(state: &WebState, who: &Identity, id: &str) -> ApiResult<JobRow> {
    let jobs = jobs_for(state, who).await?;
    let mine = jobs.iter().find(|j| j.id == id && j.user == who.user);
    mine.or_else(|| jobs.iter().find(|j| j.id == id))
        .cloned()
        .ok_or_else(|| ApiError(StatusCode::NOT_FOUND, format!("no job {id} of yours")))
}

async fn job(
    State(state): State<WebState>,
    headers: HeaderMap,
    Path(id): Path<String>,
) -> ApiResult<Json<serde_json::Value>> {
    let proof = proof(&state, &headers)?;
    let row = row(&state, proof.who(), &id).await?;
    let published = job_view::published(&state.daemon, &row.user, &row.id).await?;
    Ok(Json(json!({ "job": row, "published": published })))
}

async fn image(
    State(state): State<WebState>,
    headers: HeaderMap,
    Path(id): Path<String>,
) -> ApiResult<Response> {
    let proof = proof(&state, &headers)?;
    let row = row(&state, proof.who(), &id).await?;
    let png = job_view::image(&state.daemon, &row.user, &row.id)
        .await?
        .ok_or_else(|| {
            ApiError(
                StatusCode::NOT_FOUND,
                format!("job {id} has published no image yet"),
            )
        })?;
    Ok(png_response(png, &row.id))
}

/// Another picture of the job (`image.views` in its published view).
async fn view_image(
    State(state): State<WebState>,
    headers: HeaderMap,
    Path((id, view)): Path<(String, String)>,
) -> ApiResult<Response> {
    let proof = proof(&state, &headers)?;
    let row = row(&state, proof.who(), &id).await?;
    let png = job_view::view_image(&state.daemon, &row.user, &row.id, &view)
        .await?
        .ok_or_else(|| {
            ApiError(
                StatusCode::NOT_FOUND,
                format!("job {id} has published no picture {view:?}"),
            )
        })?;
    Ok(png_response(png, &format!("{}-{view}", row.id)))
}

/// A PNG, shown in the page and saved as `NAME.png`.
fn png_response(png: Vec<u8>, name: &str) -> Response {
    let disposition = format!("inline; filename=\"{name}.png\"");
    (
        [
            (header::CONTENT_TYPE, "image/png".to_string()),
            (header::CONTENT_DISPOSITION, disposition),
        ],
        png,
    )
        .into_response()
}

async fn cancel(
    State(state): State<WebState>,
    headers: HeaderMap,
    Path(id): Path<String>,
) -> ApiResult<Json<serde_json::Value>> {
    let proof = proof(&state, &headers)?;
    if !proof.may_change(&headers) {
        return Err(csrf_refused());
    }
    let who = proof.who();
    let record = job_view::find(&state.daemon, who, &id)
        .await?
        .ok_or_else(|| ApiError(StatusCode::NOT_FOUND, format!("no job {id} of yours")))?;
    if crate::store::job_store::is_ended(&record.state) {
        return Err(ApiError(
            StatusCode::CONFLICT,
            format!("job {id} has already ended ({})", record.state),
        ));
    }
    let ended = job_view::cancel(&state.daemon, who, &record).await?;
    tracing::info!(job = %id, by = %who.user, processes = ended, "web view: job cancelled");
    Ok(Json(json!({ "cancelled": id, "processes_ended": ended })))
}

#[derive(Deserialize)]
struct StreamQuery {
    job: Option<String>,
}

async fn stream(
    State(state): State<WebState>,
    headers: HeaderMap,
    Query(q): Query<StreamQuery>,
) -> ApiResult<Response> {
    let proof = proof(&state, &headers)?;
    let permit = state.streams.clone().try_acquire_owned().map_err(|_| {
        ApiError(
            StatusCode::SERVICE_UNAVAILABLE,
            "too many open event streams on this daemon".into(),
        )
    })?;
    let (tx, rx) = mpsc::channel(4);
    tokio::spawn(async move {
        let _permit = permit;
        feed(state, proof, q.job, tx).await;
    });
    let events = tokio_stream::wrappers::ReceiverStream::new(rx);
    Ok(Sse::new(events)
        .keep_alive(KeepAlive::new().interval(Duration::from_secs(15)))
        .into_response())
}

type Sink = mpsc::Sender<Result<Event, Infallible>>;

/// Feeds one event stream until the client goes, its session ends or the daemon stops:
/// `hosts`, `jobs` and (with `job`) `job` events, each when it differs from the last sent.
async fn feed(state: WebState, proof: Proof, job: Option<String>, tx: Sink) {
    let who = proof.who().clone();
    let mut rx = state.view.clone();
    let mut last = [String::new(), String::new(), String::new()];
    loop {
        if let Proof::Cookie { id, .. } = &proof {
            if state.sessions.get(id).is_none() {
                return;
            }
        }
        state.demand.touch();
        let view: Arc<FarmView> = rx.borrow_and_update().clone();
        let mut out = vec![("hosts", json!(view.hosts))];
        if let Some(jobs) = view.jobs_for(&who) {
            if let Some(id) = &job {
                let found = jobs.iter().find(|j| &j.id == id).cloned();
                let detail = match found {
                    None => json!({ "id": id, "error": format!("no job {id} of yours") }),
                    Some(row) => {
                        match job_view::published(&state.daemon, &row.user, &row.id).await {
                            Ok(p) => json!({ "job": row, "published": p }),
                            Err(e) => json!({ "job": row, "error": e.to_string() }),
                        }
                    }
                };
                out.push(("job", detail));
            }
            out.push(("jobs", json!(jobs)));
        }
        for (name, value) in out {
            let slot = match name {
                "hosts" => 0,
                "jobs" => 1,
                _ => 2,
            };
            let data = value.to_string();
            if data != last[slot] {
                if tx
                    .send(Ok(Event::default().event(name).data(&data)))
                    .await
                    .is_err()
                {
                    return;
                }
                last[slot] = data;
            }
        }
        tokio::select! {
            r = rx.changed() => if r.is_err() { return },
            _ = tx.closed() => return,
            _ = state.daemon.stop.cancelled() => return,
        }
    }
}
