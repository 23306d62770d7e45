//! One publication of a job's web view, taken from the [`WebView`](super::WebView) when it
//! is due and written by whoever holds the store: the page's data (table rows, events,
//! timeline) and the image as it was then. While the job runs that is a copy shrunk to
//! [`super::LIVE_SIDE`], encoded and written in [`Publication::write`], so the controller's
//! actor never waits for them; the last publication's image is encoded when it is taken, at
//! the job's end, so the whole image is never copied.

use super::{
    json_key, live_factor, png_key, view_key, Event, WebError, COLUMNS, MAX_JSON_BYTES, PUT_TIMEOUT,
};
use crate::distrib::checkpoint::Store;
use crate::film::Film;
use serde_json::{json, Value};

/// What one publication writes, as it was when it was due.
#[derive(Debug)]
pub struct Publication {
    pub(super) job: String,
    pub(super) events: Vec<Event>,
    pub(super) timeline: Vec<(&'static str, f64)>,
    /// The per-node table's rows.
    pub(super) rows: Vec<Value>,
    pub(super) image: Snapshot,
    /// Other pictures of the job ([`Publication::add_view`]): name, caption, picture.
    pub(super) views: Vec<(&'static str, String, Snapshot)>,
    /// Lines in the image.
    pub(super) lines: u32,
}

/// The image of a publication.
#[derive(Debug)]
pub(super) struct Snapshot {
    image: Image,
    /// The job's image size.
    width: u32,
    height: u32,
}

#[derive(Debug)]
enum Image {
    /// While the job runs: a copy shrunk by [`live_factor`], encoded when written.
    Live(Film),
    /// The last publication's, encoded already: whole if its PNG fits the store, else
    /// shrunk.
    Last(Result<Picture, WebError>),
}

impl Snapshot {
    /// `film` as published: a copy shrunk to [`super::LIVE_SIDE`] while the job runs; at the
    /// end (`last`) its PNG, whole if it fits `max_bytes`.
    pub(super) fn of(film: &Film, last: bool, max_bytes: usize) -> Snapshot {
        let f = live_factor(film.width, film.height);
        let image = match (last, f) {
            (true, _) => Image::Last(Picture::last(film, max_bytes)),
            (false, 1) => Image::Live(film.clone()),
            (false, f) => Image::Live(film.downscaled(f)),
        };
        Snapshot {
            image,
            width: film.width,
            height: film.height,
        }
    }

    /// The picture, encoded (taken out: an empty film is left in its place, so the rest of
    /// the publication is still at hand).
    fn take_picture(&mut self) -> Result<Picture, WebError> {
        match std::mem::replace(&mut self.image, Image::Live(Film::new(0, 0))) {
            Image::Live(film) => Picture::new(&film, false),
            Image::Last(picture) => picture,
        }
    }

    /// A black `width` x `height` image as it is published while the job runs (without
    /// making a film that large).
    pub(super) fn black(width: u32, height: u32) -> Snapshot {
        let f = live_factor(width, height);
        Snapshot {
            image: Image::Live(Film::new(width.div_ceil(f), height.div_ceil(f))),
            width,
            height,
        }
    }
}

impl Publication {
    /// Adds another picture of the job, `name` (lowercase letters, as REM's page takes them:
    /// `JOB.web.NAME.png`), described by `caption`: `film` as this publication shows its
    /// image (shrunk while the job runs; at the end, `last`, whole if it fits `max_bytes`).
    pub fn add_view(
        &mut self,
        (name, caption): (&'static str, &str),
        film: &Film,
        last: bool,
        max_bytes: usize,
    ) {
        // A name REM's page would not serve is a mistake of this program's.
        debug_assert!(rem::daemon::web::job_view::is_view_name(name), "{name}");
        let snapshot = Snapshot::of(film, last, max_bytes);
        self.views.push((name, caption.to_string(), snapshot));
    }

    /// Writes the other pictures and the image, then the page's data (so the data never
    /// describes a picture not yet stored), each within its time.
    pub async fn write(mut self, store: &impl Store) -> Result<(), WebError> {
        let (width, height) = (self.image.width, self.image.height);
        let picture = self.image.take_picture()?;
        let mut views = Vec::new();
        for (name, caption, snapshot) in &mut self.views {
            let view = snapshot.take_picture()?;
            put(store, view_key(&self.job, name), view.png).await?;
            views.push(json!({"name": name, "caption": caption}));
        }
        let mut about = json!({"width": width, "height": height, "lines": self.lines,
            "full": picture.full, "png_width": picture.width, "png_height": picture.height});
        if !views.is_empty() {
            about["views"] = Value::Array(views);
        }
        let page = self.page(about)?;
        put(store, png_key(&self.job), picture.png).await?;
        put(store, json_key(&self.job), page).await
    }

    /// The page's data, under [`MAX_JSON_BYTES`] (rows of the table are left out if there
    /// are thousands of nodes).
    fn page(&self, about: Value) -> Result<Vec<u8>, WebError> {
        let mut rows: &[Value] = &self.rows;
        loop {
            let page = json!({
                "nodes": {"columns": COLUMNS, "rows": rows},
                "events": self.events,
                "image": about,
                "timeline": self.timeline,
            });
            let bytes = serde_json::to_vec(&page)?;
            if bytes.len() <= MAX_JSON_BYTES || rows.is_empty() {
                return Ok(bytes);
            }
            rows = &rows[..rows.len() / 2];
        }
    }
}

/// The image as published.
#[derive(Debug)]
struct Picture {
    png: Vec<u8>,
    /// The finished job's image at full size (only in the last publication).
    full: bool,
    width: u32,
    height: u32,
}

impl Picture {
    fn new(film: &Film, full: bool) -> Result<Picture, WebError> {
        let (width, height) = (film.width, film.height);
        let png = film.to_png()?;
        Ok(Picture {
            png,
            full,
            width,
            height,
        })
    }

    /// The finished job's image: at full size if its PNG fits `max_bytes`, else shrunk as
    /// while the job runs.
    fn last(film: &Film, max_bytes: usize) -> Result<Picture, WebError> {
        let whole = Picture::new(film, true)?;
        if whole.png.len() <= max_bytes {
            return Ok(whole);
        }
        match live_factor(film.width, film.height) {
            1 => Ok(Picture {
                full: false,
                ..whole
            }),
            f => Picture::new(&film.downscaled(f), false),
        }
    }
}

async fn put(store: &impl Store, key: String, data: Vec<u8>) -> Result<(), WebError> {
    match tokio::time::timeout(PUT_TIMEOUT, store.put(&key, data)).await {
        Ok(Ok(())) => Ok(()),
        Ok(Err(source)) => Err(WebError::Rem { key, source }),
        Err(_) => Err(WebError::Timeout(key)),
    }
}
