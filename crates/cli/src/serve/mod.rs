//! `keycomp serve`: a local web app and HTTP JSON API over an index.
//!
//! # Routes
//! - `GET /`: the app (a page and its scripts, shipped inside the binary; the 3D view is
//!   three.js, MIT licence, at `/assets/three-LICENSE.txt`).
//! - `GET /api/index`: the index's directory, shape count, generation and profile.
//! - `GET /api/shapes?offset=&limit=&filter=`: indexed shapes by increasing id, those whose
//!   path contains `filter` (case-insensitive).
//! - `GET /api/shapes/{id}`: one shape's record: path, counts, its parts' areas.
//! - `GET /api/shapes/{id}/mesh.glb?parts=3,7`: the mesh that was analysed (the file, or its
//!   canonical surface when the index's profile has one) as GLB, parts coloured: the listed
//!   ones in that order (the k-th with the k-th colour of the palette), else the first 16;
//!   each part drawn as the region of its indexed area around its indexed centre.
//! - `GET /api/shapes/{id}/thumb.png`: a picture, rendered once and cached in
//!   `DIR/thumbnails/` under the file's content hash (so a changed file gets a new one).
//! - `POST /api/query?k=10&verify=auto`: the multipart field `file` (its name's extension
//!   picks the reader, as for `keycomp query`) ranked against the index; the answer is what
//!   `keycomp query --json` prints, with `session` (the number the query's mesh is kept under)
//!   and each result's shape `id`.
//! - `GET /api/queries/{session}/mesh.glb?hypothesis=0&parts=3,7`: that query's analysed mesh,
//!   its listed parts (`query_component`s of scale hypothesis `hypothesis`) coloured as a
//!   shape's are: the k-th listed part of the query and the k-th of a shape share a colour.
//!   The last [`sessions::KEPT`] queries are kept.
//! - `POST /api/shapes/{id}/similar?k=10`: the same with an indexed shape as the query.
//!
//! # Safety
//! Only indexed shapes' files are read (a request names a shape by id; no path from a
//! request reaches the file system). Uploads are capped ([`Options::max_upload`]) and written
//! to a private temporary folder, removed when the query ends. Each query runs as a
//! `keycomp query` child process with the same bounds as the command line, at most
//! [`Options::jobs`] at once: the child is stopped when the query outlives
//! [`Options::timeout`] or its client goes away, and a hostile file can at worst fail its own
//! process. An error is answered as `{"error": "…"}` with a 4xx status for bad input.

mod app;
mod sessions;
mod shapes;

use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use anyhow::{Context, Result};
use axum::Router;
use axum::extract::DefaultBodyLimit;
use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};

/// What `keycomp serve` serves, and its bounds.
#[derive(Debug, Clone)]
pub struct Options {
    /// The index directory.
    pub index: PathBuf,
    /// Where to listen.
    pub addr: SocketAddr,
    /// Largest request body, in bytes.
    pub max_upload: usize,
    /// Longest a query may run.
    pub timeout: Duration,
    /// Queries analysed at once.
    pub jobs: usize,
    /// Threads of each query's analysis.
    pub threads_per_job: usize,
}

/// Serves `options.index` until interrupted (Ctrl-C).
pub fn run(options: Options) -> Result<()> {
    let state = Arc::new(app::State::new(&options)?);
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .context("cannot start the server's runtime")?;
    runtime.block_on(async move {
        let listener = tokio::net::TcpListener::bind(options.addr)
            .await
            .with_context(|| format!("cannot listen on {}", options.addr))?;
        let local = listener.local_addr().context("no local address")?;
        eprintln!(
            "serving {} ({} shapes) at http://{local}/ (Ctrl-C stops)",
            options.index.display(),
            state.shape_count()
        );
        axum::serve(listener, router(state, options.max_upload))
            .with_graceful_shutdown(async {
                let _ = tokio::signal::ctrl_c().await;
            })
            .await
            .context("the server stopped")
    })
}

fn router(state: Arc<app::State>, max_upload: usize) -> Router {
    Router::new()
        .route("/", get(app::page))
        .route("/assets/{name}", get(app::asset))
        .route("/api/index", get(app::index_info))
        .route("/api/shapes", get(app::list_shapes))
        .route("/api/shapes/{id}", get(app::shape))
        .route("/api/shapes/{id}/mesh.glb", get(app::shape_glb))
        .route("/api/shapes/{id}/thumb.png", get(app::shape_thumb))
        .route("/api/shapes/{id}/similar", post(app::similar))
        .route("/api/query", post(app::query))
        .route("/api/queries/{id}/mesh.glb", get(app::query_glb))
        .layer(DefaultBodyLimit::max(max_upload))
        .with_state(state)
}

/// An error answer: a status and keycomp's message, as `{"error": "…"}`.
#[derive(Debug)]
pub(crate) struct ApiError(StatusCode, String);

impl ApiError {
    pub(crate) fn bad_request(msg: impl Into<String>) -> Self {
        ApiError(StatusCode::BAD_REQUEST, msg.into())
    }

    pub(crate) fn not_found(msg: impl Into<String>) -> Self {
        ApiError(StatusCode::NOT_FOUND, msg.into())
    }

    pub(crate) fn internal(msg: impl Into<String>) -> Self {
        ApiError(StatusCode::INTERNAL_SERVER_ERROR, msg.into())
    }
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        (self.0, axum::Json(serde_json::json!({ "error": self.1 }))).into_response()
    }
}
