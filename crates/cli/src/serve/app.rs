//! The web app's handlers: the page and its assets, the shape API and queries (each a
//! `keycomp query --json` child process).

use std::path::{Path, PathBuf};
use std::process::Stdio;
use std::sync::Arc;
use std::time::Duration;

use axum::Json;
use axum::body::Body;
use axum::extract::multipart::MultipartRejection;
use axum::extract::rejection::{PathRejection, QueryRejection};
use axum::extract::{Multipart, Path as UrlPath, Query, State as Shared};
use axum::http::{StatusCode, header};
use axum::response::{Html, IntoResponse, Response};
use serde::Deserialize;
use tokio::io::AsyncWriteExt;

use super::shapes::Index;
use super::{ApiError, Options};

/// Most results a query may ask for.
pub(crate) const MAX_K: usize = 1000;
/// Most shapes one listing page holds.
pub(crate) const MAX_PAGE: usize = 500;

/// What every handler shares.
pub(crate) struct State {
    dir: PathBuf,
    exe: PathBuf,
    index: Index,
    queries: tokio::sync::Semaphore,
    sessions: super::sessions::Sessions,
    timeout: Duration,
    threads_per_job: usize,
}

impl State {
    pub(crate) fn new(options: &Options) -> anyhow::Result<State> {
        Ok(State {
            dir: options.index.clone(),
            exe: std::env::current_exe()?,
            index: Index::open(&options.index)?,
            queries: tokio::sync::Semaphore::new(options.jobs),
            sessions: super::sessions::Sessions::default(),
            timeout: options.timeout,
            threads_per_job: options.threads_per_job,
        })
    }

    pub(crate) fn shape_count(&self) -> usize {
        self.index.snapshot().reader.len()
    }
}

type AppState = Shared<Arc<State>>;

pub(crate) async fn page() -> Html<&'static str> {
    Html(include_str!("../../assets/index.html"))
}

/// The app's scripts, style and three.js (with its licence), from the binary.
pub(crate) async fn asset(UrlPath(name): UrlPath<String>) -> Response {
    let (kind, body): (&str, &'static str) = match name.as_str() {
        "app.js" => ("text/javascript", include_str!("../../assets/app.js")),
        "style.css" => ("text/css", include_str!("../../assets/style.css")),
        "three.min.js" => (
            "text/javascript",
            include_str!("../../assets/three/three.min.js"),
        ),
        "OrbitControls.js" => (
            "text/javascript",
            include_str!("../../assets/three/OrbitControls.js"),
        ),
        "GLTFLoader.js" => (
            "text/javascript",
            include_str!("../../assets/three/GLTFLoader.js"),
        ),
        "three-LICENSE.txt" => ("text/plain", include_str!("../../assets/three/LICENSE")),
        _ => return ApiError::not_found(format!("no asset {name}")).into_response(),
    };
    (
        [
            (header::CONTENT_TYPE, kind),
            (header::CACHE_CONTROL, "max-age=3600"),
        ],
        body,
    )
        .into_response()
}

/// Runs `f` on a blocking thread.
async fn blocking<T: Send + 'static>(
    f: impl FnOnce() -> Result<T, ApiError> + Send + 'static,
) -> Result<T, ApiError> {
    tokio::task::spawn_blocking(f)
        .await
        .map_err(|e| ApiError::internal(format!("the request failed: {e}")))?
}

pub(crate) async fn index_info(
    Shared(state): AppState,
) -> Result<Json<serde_json::Value>, ApiError> {
    let st = state.clone();
    blocking(move || {
        let snap = st.index.snapshot();
        let profile: serde_json::Value =
            serde_json::from_str(snap.reader.profile()).unwrap_or(serde_json::Value::Null);
        Ok(Json(serde_json::json!({
            "dir": st.dir.display().to_string(),
            "shapes": snap.reader.len(),
            "generation": snap.reader.generation(),
            "profile": profile,
            // the folder every indexed path lies under, which the page names shapes from
            "root": common_folder(snap.rows()?.iter().map(|r| r.path.as_str())),
        })))
    })
    .await
}

/// The deepest folder holding every one of `paths` (with its trailing separator), empty when
/// they share none.
fn common_folder<'a>(paths: impl Iterator<Item = &'a str>) -> String {
    let mut common: Option<Vec<&str>> = None;
    for p in paths {
        let mut folders: Vec<&str> = p.split('/').collect();
        folders.pop(); // the file's name
        common = Some(match common {
            None => folders,
            Some(mut c) => {
                let same = c.iter().zip(&folders).take_while(|(a, b)| a == b).count();
                c.truncate(same);
                c
            }
        });
    }
    match common {
        Some(c) if !c.is_empty() => c.join("/") + "/",
        _ => String::new(),
    }
}

#[derive(Debug, Deserialize)]
pub(crate) struct ListParams {
    #[serde(default)]
    offset: usize,
    limit: Option<usize>,
    #[serde(default)]
    filter: String,
}

pub(crate) async fn list_shapes(
    Shared(state): AppState,
    p: Result<Query<ListParams>, QueryRejection>,
) -> Result<Json<serde_json::Value>, ApiError> {
    let Query(p) = rejected(p)?;
    blocking(move || {
        let snap = state.index.snapshot();
        let rows = snap.rows()?;
        let needle = p.filter.to_lowercase();
        let matched: Vec<_> = rows
            .iter()
            .filter(|r| needle.is_empty() || r.path.to_lowercase().contains(&needle))
            .collect();
        let limit = p.limit.unwrap_or(60).min(MAX_PAGE);
        let page: Vec<_> = matched.iter().skip(p.offset).take(limit).collect();
        Ok(Json(serde_json::json!({
            "total": rows.len(),
            "matched": matched.len(),
            "offset": p.offset,
            "shapes": page,
        })))
    })
    .await
}

pub(crate) async fn shape(
    Shared(state): AppState,
    id: Result<UrlPath<u64>, PathRejection>,
) -> Result<Json<serde_json::Value>, ApiError> {
    let UrlPath(id) = rejected(id)?;
    blocking(move || {
        let snap = state.index.snapshot();
        let r = snap.record(id)?;
        let parts: Vec<_> = r
            .components
            .iter()
            .map(|c| {
                serde_json::json!({
                    "centre_vertex": c.centre_vertex,
                    "area_fraction": c.area_fraction,
                    "keypoints": c.keypoint_count,
                })
            })
            .collect();
        Ok(Json(serde_json::json!({
            "id": id,
            "path": r.path.display().to_string(),
            "content_hash": r.content_hash.to_hex(),
            "vertices": r.vertex_count,
            "faces": r.face_count,
            "surface_area": r.surface_area,
            "boundary_vertices": r.boundary_vertices,
            "parts": parts,
        })))
    })
    .await
}

#[derive(Debug, Deserialize)]
pub(crate) struct GlbParams {
    parts: Option<String>,
}

pub(crate) async fn shape_glb(
    Shared(state): AppState,
    id: Result<UrlPath<u64>, PathRejection>,
    p: Result<Query<GlbParams>, QueryRejection>,
) -> Result<Response, ApiError> {
    let (UrlPath(id), Query(p)) = (rejected(id)?, rejected(p)?);
    let parts = parse_parts(p.parts.as_deref())?;
    glb(blocking(move || state.index.glb(id, parts)).await?)
}

/// A GLB answer.
fn glb(bytes: Vec<u8>) -> Result<Response, ApiError> {
    Ok(([(header::CONTENT_TYPE, "model/gltf-binary")], bytes).into_response())
}

/// A `parts` parameter: part numbers separated by commas (none: `None`), at most [`MAX_K`].
fn parse_parts(list: Option<&str>) -> Result<Option<Vec<usize>>, ApiError> {
    let Some(list) = list.filter(|l| !l.is_empty()) else {
        return Ok(None);
    };
    let parts = list
        .split(',')
        .map(|s| s.trim().parse::<usize>())
        .collect::<Result<Vec<_>, _>>()
        .map_err(|_| {
            ApiError::bad_request(format!(
                "parts: expected part numbers separated by commas, got '{list}'"
            ))
        })?;
    if parts.len() > MAX_K {
        return Err(ApiError::bad_request(format!("parts: at most {MAX_K}")));
    }
    Ok(Some(parts))
}

#[derive(Debug, Deserialize)]
pub(crate) struct QueryGlbParams {
    #[serde(default)]
    hypothesis: usize,
    parts: Option<String>,
}

/// The analysed mesh of a query this server answered, its listed parts coloured as
/// [`shape_glb`] colours a shape's.
pub(crate) async fn query_glb(
    Shared(state): AppState,
    id: Result<UrlPath<u64>, PathRejection>,
    p: Result<Query<QueryGlbParams>, QueryRejection>,
) -> Result<Response, ApiError> {
    let (UrlPath(id), Query(p)) = (rejected(id)?, rejected(p)?);
    let parts = parse_parts(p.parts.as_deref())?.unwrap_or_default();
    let session = state.sessions.get(id).ok_or_else(|| {
        ApiError::not_found(format!(
            "query {id} is no longer kept (the last {} are): run it again",
            super::sessions::KEPT
        ))
    })?;
    glb(blocking(move || Ok(session.glb(p.hypothesis, &parts))).await?)
}

pub(crate) async fn shape_thumb(
    Shared(state): AppState,
    id: Result<UrlPath<u64>, PathRejection>,
) -> Result<Response, ApiError> {
    let UrlPath(id) = rejected(id)?;
    let bytes = blocking(move || state.index.thumbnail(id)).await?;
    Ok((
        [
            (header::CONTENT_TYPE, "image/png"),
            (header::CACHE_CONTROL, "max-age=60"),
        ],
        bytes,
    )
        .into_response())
}

#[derive(Debug, Deserialize)]
pub(crate) struct QueryParams {
    k: Option<usize>,
    verify: Option<String>,
}

impl QueryParams {
    /// The `keycomp query` arguments these stand for, checked.
    fn args(&self) -> Result<Vec<String>, ApiError> {
        let k = self.k.unwrap_or(10);
        if !(1..=MAX_K).contains(&k) {
            return Err(ApiError::bad_request(format!(
                "k: expected 1 to {MAX_K}, got {k}"
            )));
        }
        let verify = match self.verify.as_deref() {
            None | Some("auto") => "auto".to_string(),
            Some(w) => match w.parse::<f64>() {
                Ok(x) if (0.0..=1.0).contains(&x) => x.to_string(),
                _ => {
                    return Err(ApiError::bad_request(format!(
                        "verify: expected 'auto' or a weight in [0, 1], got '{w}'"
                    )));
                }
            },
        };
        Ok(vec!["-k".into(), k.to_string(), "--verify".into(), verify])
    }
}

/// The name an upload is saved and reported under: its file name's last component, with
/// characters other than letters, digits, `.`, `-` and `_` replaced, at most 100 of them.
fn upload_name(given: Option<&str>) -> String {
    let base = given
        .unwrap_or("")
        .rsplit(['/', '\\'])
        .next()
        .unwrap_or("")
        .trim_start_matches('.');
    let clean: String = base
        .chars()
        .rev()
        .take(100)
        .collect::<Vec<_>>()
        .into_iter()
        .rev()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '.' | '-' | '_') {
                c
            } else {
                '_'
            }
        })
        .collect();
    if clean.is_empty() {
        "upload".into()
    } else {
        clean
    }
}

pub(crate) async fn query(
    Shared(state): AppState,
    p: Result<Query<QueryParams>, QueryRejection>,
    multipart: Result<Multipart, MultipartRejection>,
) -> Result<Response, ApiError> {
    let args = rejected(p)?.0.args()?;
    let mut multipart = rejected(multipart)?;
    let dir = tempfile::Builder::new()
        .prefix("keycomp-serve-")
        .tempdir()
        .map_err(|e| ApiError::internal(format!("no temporary folder: {e}")))?;
    let mut saved: Option<(PathBuf, String)> = None;
    while let Some(mut field) = multipart.next_field().await.map_err(multipart_error)? {
        if field.name() != Some("file") || saved.is_some() {
            continue;
        }
        let name = upload_name(field.file_name());
        let path = dir.path().join(&name);
        let mut out = tokio::fs::File::create(&path)
            .await
            .map_err(|e| ApiError::internal(format!("cannot save the upload: {e}")))?;
        while let Some(chunk) = field.chunk().await.map_err(multipart_error)? {
            out.write_all(&chunk)
                .await
                .map_err(|e| ApiError::internal(format!("cannot save the upload: {e}")))?;
        }
        out.flush()
            .await
            .map_err(|e| ApiError::internal(format!("cannot save the upload: {e}")))?;
        saved = Some((path, name));
    }
    let Some((path, name)) = saved else {
        return Err(ApiError::bad_request(
            "no file: send the mesh as the multipart field 'file'",
        ));
    };
    let answer = run_query(&state, &path, &name, &args).await;
    drop(dir);
    answer
}

/// What an extractor refused, as a JSON error with its status.
trait Rejected {
    fn api_error(self) -> ApiError;
}

macro_rules! rejection {
    ($($t:ty),*) => {$(
        impl Rejected for $t {
            fn api_error(self) -> ApiError {
                ApiError(self.status(), self.body_text())
            }
        }
    )*};
}
rejection!(PathRejection, QueryRejection, MultipartRejection);

fn rejected<T, R: Rejected>(r: Result<T, R>) -> Result<T, ApiError> {
    r.map_err(Rejected::api_error)
}

fn multipart_error(e: axum::extract::multipart::MultipartError) -> ApiError {
    ApiError(e.status(), e.body_text())
}

pub(crate) async fn similar(
    Shared(state): AppState,
    id: Result<UrlPath<u64>, PathRejection>,
    p: Result<Query<QueryParams>, QueryRejection>,
) -> Result<Response, ApiError> {
    let (UrlPath(id), Query(p)) = (rejected(id)?, rejected(p)?);
    let args = p.args()?;
    let st = state.clone();
    let record = blocking(move || st.index.snapshot().record(id)).await?;
    let shown = record.path.display().to_string();
    run_query(&state, &record.canonical_path, &shown, &args).await
}

/// Runs `keycomp query --json` on `file` (reported as `shown`) when a slot is free: its JSON,
/// or its error as 400 (bad input), 504 (too long) or 500.
async fn run_query(
    state: &State,
    file: &Path,
    shown: &str,
    args: &[String],
) -> Result<Response, ApiError> {
    let _slot = state
        .queries
        .acquire()
        .await
        .map_err(|_| ApiError::internal("the server is stopping"))?;
    let scratch = tempfile::Builder::new()
        .prefix("keycomp-serve-")
        .tempdir()
        .map_err(|e| ApiError::internal(format!("no temporary folder: {e}")))?;
    let analysis = scratch.path().join("analysis.json");
    let child = tokio::process::Command::new(&state.exe)
        .arg("query")
        .arg("--analysis-out")
        .arg(&analysis)
        .arg("--index")
        .arg(&state.dir)
        .arg("--json")
        .args(args)
        .arg(file)
        .env("RAYON_NUM_THREADS", state.threads_per_job.to_string())
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        // the query stops with its request: on timeout, or when the client goes away
        .kill_on_drop(true)
        .spawn()
        .map_err(|e| ApiError::internal(format!("cannot run keycomp query: {e}")))?;
    let out = tokio::time::timeout(state.timeout, child.wait_with_output())
        .await
        .map_err(|_| {
            ApiError(
                StatusCode::GATEWAY_TIMEOUT,
                format!(
                    "{shown}: the query took longer than {} s and was stopped",
                    state.timeout.as_secs()
                ),
            )
        })?
        .map_err(|e| ApiError::internal(format!("keycomp query failed: {e}")))?;
    let file_text = file.display().to_string();
    if !out.status.success() {
        let text = String::from_utf8_lossy(&out.stderr).replace(&file_text, shown);
        let message = text
            .lines()
            .filter(|l| !l.starts_with("warning:"))
            .map(|l| l.trim_start_matches("error: "))
            .collect::<Vec<_>>()
            .join("\n");
        let status = match out.status.code() {
            Some(2) => StatusCode::BAD_REQUEST,
            _ => StatusCode::INTERNAL_SERVER_ERROR,
        };
        let message = if message.trim().is_empty() {
            format!("{shown}: the query failed ({})", out.status)
        } else {
            message
        };
        return Err(ApiError(status, message));
    }
    let mut answer: serde_json::Value = serde_json::from_slice(&out.stdout)
        .map_err(|e| ApiError::internal(format!("keycomp query printed no JSON: {e}")))?;
    answer["query"] = serde_json::Value::String(shown.to_string());
    let session = blocking(move || {
        let text = std::fs::read(&analysis)
            .map_err(|e| ApiError::internal(format!("keycomp query wrote no analysis: {e}")))?;
        drop(scratch);
        super::sessions::Session::from_json(&text).map_err(ApiError::internal)
    })
    .await?;
    answer["session"] = serde_json::json!(state.sessions.insert(session));
    // each result's shape id, for the shape routes (the index may have committed since the
    // query read it: a path it no longer has gets none)
    let snap = state.index.snapshot();
    let mut answer = blocking(move || {
        if let Some(results) = answer["results"].as_array_mut() {
            for hit in results {
                let id = match hit["path"].as_str() {
                    Some(p) => snap.id_of(p)?,
                    None => None,
                };
                hit["id"] = serde_json::json!(id);
            }
        }
        Ok(answer)
    })
    .await?;
    let warnings: Vec<String> = String::from_utf8_lossy(&out.stderr)
        .lines()
        .filter_map(|l| l.strip_prefix("warning: "))
        .map(|l| l.replace(&file_text, shown))
        .collect();
    answer["warnings"] = serde_json::json!(warnings);
    Ok((
        [(header::CONTENT_TYPE, "application/json")],
        Body::from(answer.to_string()),
    )
        .into_response())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_common_folder_ends_at_a_separator() {
        let f = |p: &[&str]| common_folder(p.iter().copied());
        assert_eq!(f(&["/d/shapes/a.off", "/d/shapes/b.off"]), "/d/shapes/");
        assert_eq!(f(&["/d/shapes/a.off", "/d/shapes/sub/b.off"]), "/d/shapes/");
        assert_eq!(f(&["/d/shapes1/a.off", "/d/shapes2/b.off"]), "/d/");
        assert_eq!(f(&["a.off", "/d/b.off"]), "");
        assert_eq!(f(&["/d/é/a.off", "/d/é/b.off"]), "/d/é/");
        assert_eq!(f(&[]), "");
    }

    #[test]
    fn upload_names_keep_only_a_safe_base_name() {
        assert_eq!(upload_name(Some("bunny.ply")), "bunny.ply");
        assert_eq!(upload_name(Some("../../etc/passwd")), "passwd");
        assert_eq!(upload_name(Some("C:\\scans\\a b.obj")), "a_b.obj");
        assert_eq!(upload_name(Some("..")), "upload");
        assert_eq!(upload_name(Some(".hidden.off")), "hidden.off");
        assert_eq!(upload_name(None), "upload");
        let long = format!("{}.off", "x".repeat(300));
        let n = upload_name(Some(&long));
        assert_eq!(n.len(), 100);
        assert!(n.ends_with(".off"));
    }

    #[test]
    fn query_parameters_are_checked() {
        let p = |k: Option<usize>, v: Option<&str>| QueryParams {
            k,
            verify: v.map(str::to_string),
        };
        assert_eq!(
            p(None, None).args().unwrap(),
            ["-k", "10", "--verify", "auto"]
        );
        assert_eq!(p(Some(3), Some("0.5")).args().unwrap()[3], "0.5");
        assert!(p(Some(0), None).args().is_err());
        assert!(p(Some(MAX_K + 1), None).args().is_err());
        assert!(p(None, Some("2")).args().is_err());
        assert!(p(None, Some("x; rm -rf")).args().is_err());
    }
}
