//! One publication of a job's web view, taken from the [`WebView`](super::WebView) when it
//! is due and written by whoever holds the store: the page's data (table rows, events,
//! timeline) and a copy of the image as they were then. Encoding the PNG and the JSON and
//! both writes happen in [`Publication::write`], so the controller's actor, which only takes
//! the copy, never waits for them.

use super::{
    json_key, live_factor, png_key, Event, WebError, COLUMNS, MAX_JSON_BYTES, PUT_TIMEOUT,
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
    /// Lines in the image.
    pub(super) lines: u32,
}

/// The image of a publication.
#[derive(Debug)]
pub(super) struct Snapshot {
    /// The image, shrunk by [`live_factor`] unless `last`.
    film: Film,
    /// The job's image size.
    width: u32,
    height: u32,
    /// The last publication's: whole if its PNG fits the store, else shrunk.
    last: bool,
}

impl Snapshot {
    /// A copy of `film` as published: shrunk to [`super::LIVE_SIDE`] while the job runs;
    /// whole at the end (`last`; [`Publication::write`] shrinks it if it does not fit).
    pub(super) fn of(film: &Film, last: bool) -> Snapshot {
        let f = live_factor(film.width, film.height);
        Snapshot {
            film: if last || f == 1 {
                film.clone()
            } else {
                film.downscaled(f)
            },
            width: film.width,
            height: film.height,
            last,
        }
    }

    /// A black `width` x `height` image as it is published while the job runs (without
    /// making a film that large).
    pub(super) fn black(width: u32, height: u32) -> Snapshot {
        let f = live_factor(width, height);
        Snapshot {
            film: Film::new(width.div_ceil(f), height.div_ceil(f)),
            width,
            height,
            last: false,
        }
    }
}

impl Publication {
    /// Writes the image, then the page's data (so the data never describes an image not yet
    /// stored), each within its time.
    pub async fn write(self, store: &impl Store) -> Result<(), WebError> {
        let image = &self.image;
        let picture = Picture::of(&image.film, image.last, store.max_bytes())?;
        let about = json!({"width": image.width, "height": image.height, "lines": self.lines,
            "full": picture.full, "png_width": picture.width, "png_height": picture.height});
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

    /// `film` as a snapshot holds it; at the end (`last`, a whole film) at full size if its
    /// PNG fits `max_bytes`, else shrunk as while running.
    fn of(film: &Film, last: bool, max_bytes: usize) -> Result<Picture, WebError> {
        if !last {
            return Picture::new(film, false);
        }
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
