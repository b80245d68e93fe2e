//! End-to-end tests of `keycomp serve` through a real HTTP client (ureq): a small collection
//! generated in code is indexed and served; the shape API, GLB and thumbnails, a query by
//! upload, hostile uploads, and an `index add` while the server runs.

mod common;

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

use common::{chromium, headless, keycomp, s, stderr};
use keycomp_shapes::{Class, GenerateParams, generate};
use rand::SeedableRng;
use serde_json::Value;

/// A child process, stopped when dropped.
struct Process(Child);

impl Drop for Process {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// A running `keycomp serve` and its address.
struct Server {
    _process: Process,
    base: String,
}

/// WebGL on SwiftShader (no GPU), and the window of every screenshot.
const WEBGL: [&str; 4] = [
    "--use-gl=angle",
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
    "--window-size=1000,700",
];

/// Starts `keycomp serve` on a free port of 127.0.0.1 and waits for its address line.
fn serve(index: &Path, extra: &[&str]) -> Server {
    let mut child = Command::new(env!("CARGO_BIN_EXE_keycomp"))
        .args(["serve", "--index", s(index), "--addr", "127.0.0.1:0"])
        .args(extra)
        .stderr(Stdio::piped())
        .stdout(Stdio::null())
        .spawn()
        .expect("keycomp serve starts");
    let mut line = String::new();
    BufReader::new(child.stderr.take().expect("stderr"))
        .read_line(&mut line)
        .expect("reads the address line");
    let base = line
        .split("http://")
        .nth(1)
        .and_then(|t| t.split('/').next())
        .map(|a| format!("http://{a}"))
        .unwrap_or_else(|| panic!("no address in {line:?}"));
    Server {
        _process: Process(child),
        base,
    }
}

fn agent() -> ureq::Agent {
    ureq::Agent::config_builder()
        .http_status_as_error(false)
        .build()
        .into()
}

/// GET `path`: status and body bytes.
fn get(server: &Server, path: &str) -> (u16, Vec<u8>) {
    let mut r = agent()
        .get(&format!("{}{path}", server.base))
        .call()
        .expect("GET answers");
    let status = r.status().as_u16();
    let body = r
        .body_mut()
        .with_config()
        .limit(64 << 20)
        .read_to_vec()
        .expect("body");
    (status, body)
}

fn json(bytes: &[u8]) -> Value {
    serde_json::from_slice(bytes)
        .unwrap_or_else(|e| panic!("not JSON ({e}): {}", String::from_utf8_lossy(bytes)))
}

const BOUNDARY: &str = "keycomp-test-boundary-7f3a";

/// A multipart body carrying `file` as the field `file` named `name`, and its content type.
fn multipart(name: &str, file: &[u8]) -> (Vec<u8>, String) {
    let mut body = format!(
        "--{BOUNDARY}\r\nContent-Disposition: form-data; name=\"file\"; filename=\"{name}\"\r\nContent-Type: application/octet-stream\r\n\r\n"
    )
    .into_bytes();
    body.extend_from_slice(file);
    body.extend_from_slice(format!("\r\n--{BOUNDARY}--\r\n").as_bytes());
    (body, format!("multipart/form-data; boundary={BOUNDARY}"))
}

/// POST `path` with `file` as the multipart field `file` named `name`: status and JSON.
fn upload(server: &Server, path: &str, name: &str, file: &[u8]) -> (u16, Value) {
    let (body, kind) = multipart(name, file);
    let mut r = agent()
        .post(&format!("{}{path}", server.base))
        .header("Content-Type", &kind)
        .send(&body[..])
        .expect("POST answers");
    let status = r.status().as_u16();
    let text = r.body_mut().read_to_string().expect("body");
    (status, json(text.as_bytes()))
}

fn off_bytes(mesh: &keycomp_mesh::Mesh) -> Vec<u8> {
    let dir = tempfile::tempdir().expect("tempdir");
    let p = dir.path().join("m.off");
    keycomp_mesh::write_off(mesh, &p).expect("writes");
    std::fs::read(p).expect("reads")
}

/// Two shapes of each of `classes` written to `dir/shapes` and indexed in `dir/index`: the
/// index and the shapes (name, mesh).
fn collection(dir: &Path, classes: &[Class]) -> (PathBuf, Vec<(String, keycomp_mesh::Mesh)>) {
    let coll = dir.join("shapes");
    std::fs::create_dir(&coll).expect("mkdir");
    let params = GenerateParams {
        target_vertices: 4000,
        ..GenerateParams::default()
    };
    let mut meshes = Vec::new();
    for &class in classes {
        for i in 0..2 {
            let shape = generate(class, i, &params).expect("generates");
            keycomp_mesh::write_off(&shape.mesh, &coll.join(format!("{}.off", shape.name)))
                .expect("writes");
            meshes.push((shape.name, shape.mesh));
        }
    }
    let index = dir.join("index");
    let o = keycomp(&["index", "add", s(&coll), "--index", s(&index)]);
    assert!(o.status.success(), "{}", stderr(&o));
    (index, meshes)
}

#[test]
fn serve_answers_the_api_and_survives_hostile_uploads() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let (index, meshes) = collection(tmp.path(), &[Class::Humanoid, Class::Mug, Class::Octopus]);
    let params = GenerateParams {
        target_vertices: 4000,
        ..GenerateParams::default()
    };
    let server = serve(&index, &["--max-upload-mb", "1"]);

    // the index and its shapes
    let (status, body) = get(&server, "/api/index");
    assert_eq!(status, 200);
    assert_eq!(json(&body)["shapes"], 6);
    let (status, body) = get(&server, "/api/shapes?limit=100");
    assert_eq!(status, 200);
    let list = json(&body);
    assert_eq!(list["total"], 6);
    let shapes = list["shapes"].as_array().expect("shapes");
    assert_eq!(shapes.len(), 6);
    let (_, body) = get(&server, "/api/shapes?filter=MUG");
    assert_eq!(json(&body)["matched"], 2, "the filter ignores case");
    let (_, body) = get(&server, "/api/shapes?limit=2&offset=5");
    assert_eq!(json(&body)["shapes"].as_array().map(Vec::len), Some(1));

    let first = &shapes[0];
    let id = first["id"].as_u64().expect("id");
    let (status, body) = get(&server, &format!("/api/shapes/{id}"));
    assert_eq!(status, 200);
    let record = json(&body);
    assert_eq!(record["path"], first["path"]);
    assert!(!record["parts"].as_array().expect("parts").is_empty());

    // its mesh as GLB: the file's mesh, with colours
    let (status, glb) = get(&server, &format!("/api/shapes/{id}/mesh.glb?parts=0,2"));
    assert_eq!(status, 200);
    let back = keycomp_mesh::read_mesh_from_bytes(&glb, keycomp_mesh::Format::Gltf)
        .expect("a GLB keycomp reads")
        .mesh;
    assert_eq!(
        back.num_vertices() as u64,
        record["vertices"].as_u64().unwrap()
    );
    assert!(String::from_utf8_lossy(&glb[..glb.len().min(2000)]).contains("COLOR_0"));
    let (status, body) = get(&server, &format!("/api/shapes/{id}/mesh.glb?parts=a"));
    assert_eq!(status, 400, "{}", String::from_utf8_lossy(&body));

    // a thumbnail, rendered once and kept beside the index
    let (status, png) = get(&server, &format!("/api/shapes/{id}/thumb.png"));
    assert_eq!(status, 200);
    assert!(png.starts_with(b"\x89PNG"));
    let kept = index.join("thumbnails");
    assert_eq!(std::fs::read_dir(&kept).expect("thumbnails").count(), 1);
    assert_eq!(get(&server, &format!("/api/shapes/{id}/thumb.png")).1, png);

    // unknown shapes, assets and paths are 404; a request path never reaches the disk
    assert_eq!(get(&server, "/api/shapes/999999").0, 404);
    assert_eq!(get(&server, "/assets/..%2F..%2FCargo.toml").0, 404);
    assert_eq!(get(&server, "/assets/app.js").0, 200);
    let (status, page) = get(&server, "/");
    assert_eq!(status, 200);
    assert!(String::from_utf8_lossy(&page).contains("three.min.js"));

    // a query by upload: a fragment (a plane cut keeping 60 % of the area) finds its source
    let (source_name, source) = &meshes[2];
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let fragment =
        keycomp_fragment::cut_fragment(source, keycomp_fragment::PartialKind::Plane, 0.6, &mut rng)
            .expect("cuts");
    let (status, answer) = upload(
        &server,
        "/api/query?k=3",
        "piece of a mug.off",
        &off_bytes(&fragment.mesh),
    );
    assert_eq!(status, 200, "{answer}");
    assert_eq!(answer["query"], "piece_of_a_mug.off");
    assert!(answer["warnings"].is_array(), "{answer}");
    let top = answer["results"][0]["path"].as_str().expect("a result");
    let top_id = answer["results"][0]["id"].as_u64().expect("its shape id");
    let (_, body) = get(&server, &format!("/api/shapes/{top_id}"));
    assert_eq!(json(&body)["path"], top);
    assert!(
        top.ends_with(&format!("{source_name}.off")),
        "{top} is not {source_name}"
    );
    assert!(answer["results"].as_array().unwrap().len() <= 3);
    // the query's analysed mesh is kept for the 3D view, its matched parts coloured
    let session = answer["session"].as_u64().expect("a session");
    let hit = &answer["results"][0];
    let parts: Vec<String> = hit["matches"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["query_component"].to_string())
        .collect();
    let (status, glb) = get(
        &server,
        &format!(
            "/api/queries/{session}/mesh.glb?hypothesis={}&parts={}",
            hit["hypothesis"],
            parts.join(",")
        ),
    );
    assert_eq!(status, 200);
    let query_mesh = keycomp_mesh::read_mesh_from_bytes(&glb, keycomp_mesh::Format::Gltf)
        .expect("a GLB keycomp reads")
        .mesh;
    // the query as analysed: its canonical surface under the result's scale hypothesis, on
    // the fragment (its vertices projected onto it)
    assert!(query_mesh.num_faces() > 100);
    let (fb, qb) = (
        keycomp_mesh::geometry::bounding_box(&fragment.mesh),
        keycomp_mesh::geometry::bounding_box(&query_mesh),
    );
    // (a vertex whose projection would flatten a face stays up to the offset, about a
    // hundredth of the size, outside)
    let slack = 0.02 * fb.diagonal();
    for axis in 0..3 {
        assert!(qb.min[axis] >= fb.min[axis] - slack && qb.max[axis] <= fb.max[axis] + slack);
    }
    assert_eq!(get(&server, "/api/queries/9999/mesh.glb").0, 404);
    // "find similar" on an indexed shape ranks that shape first
    let mut r = agent()
        .post(&format!("{}/api/shapes/{id}/similar?k=2", server.base))
        .send_empty()
        .expect("POST answers");
    assert_eq!(r.status().as_u16(), 200);
    let similar = json(r.body_mut().read_to_string().unwrap().as_bytes());
    assert_eq!(similar["results"][0]["path"], first["path"]);

    // hostile and malformed uploads: 4xx with keycomp's message naming the upload
    let truncated = b"OFF\n4 2 0\n0 0 0\n1 0 0\n";
    let (status, e) = upload(&server, "/api/query", "cut.off", truncated);
    assert_eq!(status, 400, "{e}");
    assert!(e["error"].as_str().unwrap().starts_with("cut.off: "), "{e}");
    assert!(
        !e["error"].as_str().unwrap().contains("keycomp-serve-"),
        "{e}"
    );
    let (status, e) = upload(
        &server,
        "/api/query",
        "many.off",
        b"OFF\n4000000000 4000000000 0\n0 0 0\n",
    );
    assert_eq!(status, 400, "{e}");
    let (status, e) = upload(&server, "/api/query", "picture.png", b"\x89PNG\r\n\x1a\n");
    assert_eq!(status, 400, "{e}");
    assert!(
        e["error"].as_str().unwrap().contains("unknown file format"),
        "{e}"
    );
    // a 1 GB body against the 1 MB cap: 413, or the connection closed while the client still
    // sends (the server answers and stops reading); either way the server goes on
    let head = format!(
        "--{BOUNDARY}\r\nContent-Disposition: form-data; name=\"file\"; filename=\"huge.off\"\r\n\r\n"
    );
    let mut body = std::io::Read::chain(
        head.as_bytes(),
        std::io::Read::take(std::io::repeat(b'1'), 1 << 30),
    );
    let t = std::time::Instant::now();
    let huge = agent()
        .post(&format!("{}/api/query", server.base))
        .header(
            "Content-Type",
            &format!("multipart/form-data; boundary={BOUNDARY}"),
        )
        .send(ureq::SendBody::from_reader(&mut body));
    match huge {
        Ok(r) => assert_eq!(r.status().as_u16(), 413),
        Err(e) => assert!(
            matches!(e, ureq::Error::Io(_)),
            "the huge upload failed otherwise: {e}"
        ),
    }
    assert!(
        t.elapsed().as_secs() < 30,
        "the server read far past its cap"
    );
    let (status, e) = upload(&server, "/api/query?k=0", "cut.off", truncated);
    assert_eq!(status, 400, "{e}");
    let mut r = agent()
        .post(&format!("{}/api/query", server.base))
        .send_empty()
        .expect("POST answers");
    assert_eq!(r.status().as_u16(), 400);
    assert!(json(r.body_mut().read_to_string().unwrap().as_bytes())["error"].is_string());
    // no upload is left behind
    let left: Vec<_> = std::fs::read_dir(std::env::temp_dir())
        .expect("ls")
        .filter_map(|e| e.ok())
        .filter(|e| {
            e.file_name()
                .to_string_lossy()
                .starts_with("keycomp-serve-")
                && e.path().join("cut.off").exists()
        })
        .collect();
    assert!(left.is_empty(), "{left:?}");

    // the server still answers, and sees a shape added by another process once committed
    let extra = generate(Class::Bird, 0, &params).expect("generates");
    let extra_path = tmp.path().join("bird.off");
    keycomp_mesh::write_off(&extra.mesh, &extra_path).expect("writes");
    let o = keycomp(&["index", "add", s(&extra_path), "--index", s(&index)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (status, body) = get(&server, "/api/index");
    assert_eq!(status, 200);
    assert_eq!(json(&body)["shapes"], 7);
}

/// A PNG screenshot's width and pixels (RGB, row by row).
fn pixels(png_bytes: &[u8]) -> (usize, Vec<[u8; 3]>) {
    let mut reader = png::Decoder::new(std::io::Cursor::new(png_bytes))
        .read_info()
        .expect("a PNG");
    let mut buf = vec![0; reader.output_buffer_size().expect("size")];
    let info = reader.next_frame(&mut buf).expect("decodes");
    let step = info.color_type.samples();
    let px = buf[..info.buffer_size()]
        .chunks_exact(step)
        .map(|p| [p[0], p[1], p[2]])
        .collect();
    (info.width as usize, px)
}

/// A 1000 × 700 screenshot of `url` (WebGL on SwiftShader) written to `file`: its width and
/// pixels. The browser profile is a fresh folder under `tmp`.
fn screenshot(browser: &Path, tmp: &Path, file: &Path, url: &str) -> (usize, Vec<[u8; 3]>) {
    let profile = tempfile::tempdir_in(tmp).expect("profile folder");
    let out = headless(browser, profile.path())
        .args(WEBGL)
        .args([
            "--virtual-time-budget=20000",
            &format!("--screenshot={}", file.display()),
            url,
        ])
        .output()
        .expect("chromium runs");
    assert!(file.is_file(), "{}", String::from_utf8_lossy(&out.stderr));
    pixels(&std::fs::read(file).expect("screenshot"))
}

/// Asserts that both halves of a screenshot `width` pixels wide (the query's pane and the
/// result's) show coloured parts.
fn both_panes_coloured(width: usize, px: &[[u8; 3]]) {
    let (left, right): (Vec<_>, Vec<_>) = (0..px.len()).partition(|i| i % width < width / 2);
    for (side, idx) in [("query", left), ("result", right)] {
        let n = idx.iter().filter(|&&i| coloured(px[i])).count();
        assert!(
            n > idx.len() / 500,
            "the {side} pane shows no coloured part: {n} of {} pixels",
            idx.len()
        );
    }
}

/// A saturated pixel: a part's colour (the page itself is black, white and greys).
fn coloured(p: [u8; 3]) -> bool {
    let (lo, hi) = (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]));
    hi - lo > 80
}

/// The app in headless Chromium: the collection's grid fills with every shape; a shape ranked
/// against the collection shows, with a result opened, the query and the result side by side
/// with matched parts coloured; a shape opened alone is drawn with its parts in colour (WebGL
/// on SwiftShader). The screenshots are kept in `target/tmp/serve-screenshots/`. Skipped
/// without Chromium.
#[test]
fn the_app_draws_in_a_browser() {
    let Some(browser) = chromium() else {
        eprintln!("skipping the browser check: no chromium found (apt-get install chromium)");
        return;
    };
    let tmp = tempfile::tempdir().expect("tempdir");
    let (index, _) = collection(tmp.path(), &[Class::Humanoid, Class::Mug]);
    let server = serve(&index, &[]);
    let shots = Path::new(env!("CARGO_TARGET_TMPDIR")).join("serve-screenshots");
    std::fs::create_dir_all(&shots).expect("mkdir");

    let dom = headless(&browser, &tmp.path().join("profile-1"))
        .args(["--dump-dom", &format!("{}/", server.base)])
        .output()
        .expect("chromium runs");
    let dom = String::from_utf8_lossy(&dom.stdout);
    assert_eq!(dom.matches("class=\"card\"").count(), 4, "{dom}");
    assert_eq!(dom.matches("/thumb.png").count(), 4, "{dom}");

    // a shape ranked against the collection, its second result opened beside the query
    let (width, px) = screenshot(
        &browser,
        tmp.path(),
        &shots.join("similar.png"),
        &format!("{}/#similar=0&open=2", server.base),
    );
    both_panes_coloured(width, &px);

    // a shape opened alone
    let (_, px) = screenshot(
        &browser,
        tmp.path(),
        &shots.join("view.png"),
        &format!("{}/#view=0", server.base),
    );
    let n = px.iter().filter(|&&p| coloured(p)).count();
    assert!(
        n > px.len() / 500,
        "the 3D view shows no coloured part: {n} of {} pixels",
        px.len()
    );
}

/// A page of headless Chromium driven through the DevTools protocol (its websocket): for what
/// a command-line flag cannot do, such as dropping a file on the page.
struct Devtools {
    _browser: Process,
    ws: tungstenite::WebSocket<tungstenite::stream::MaybeTlsStream<std::net::TcpStream>>,
    session: String,
    next: u64,
}

impl Devtools {
    /// Opens `url` in a new headless `browser` with a fresh profile in `profile`.
    fn open(browser: &Path, profile: &Path, url: &str) -> Devtools {
        let mut child = Command::new(browser)
            .args([
                "--headless",
                "--no-sandbox",
                "--no-first-run",
                "--disable-background-networking",
                "--disable-component-update",
                "--disable-sync",
                "--remote-debugging-port=0",
                "about:blank",
            ])
            .args(WEBGL)
            .arg(format!("--user-data-dir={}", profile.display()))
            .stderr(Stdio::piped())
            .stdout(Stdio::null())
            .spawn()
            .expect("chromium runs");
        let mut lines = BufReader::new(child.stderr.take().expect("stderr")).lines();
        let ws_url = lines
            .by_ref()
            .map_while(Result::ok)
            .find_map(|l| {
                l.split_once("DevTools listening on ")
                    .map(|(_, u)| u.trim().to_string())
            })
            .expect("chromium prints its DevTools address");
        // keep reading its stderr so that it never blocks on a full pipe
        std::thread::spawn(move || lines.for_each(drop));
        let (ws, _) = tungstenite::connect(ws_url.as_str()).expect("DevTools websocket");
        let mut d = Devtools {
            _browser: Process(child),
            ws,
            session: String::new(),
            next: 0,
        };
        let target = d.call("Target.createTarget", serde_json::json!({ "url": url }));
        let attached = d.call(
            "Target.attachToTarget",
            serde_json::json!({ "targetId": target["targetId"], "flatten": true }),
        );
        d.session = attached["sessionId"].as_str().expect("session").to_string();
        d
    }

    /// Calls `method` (on the page once attached) and returns its result.
    fn call(&mut self, method: &str, params: Value) -> Value {
        self.next += 1;
        let mut msg = serde_json::json!({ "id": self.next, "method": method, "params": params });
        if !self.session.is_empty() {
            msg["sessionId"] = Value::String(self.session.clone());
        }
        self.ws
            .send(tungstenite::Message::text(msg.to_string()))
            .expect("sends");
        loop {
            let text = match self.ws.read().expect("reads") {
                tungstenite::Message::Text(t) => t,
                _ => continue,
            };
            let answer: Value = serde_json::from_str(text.as_str()).expect("JSON");
            if answer["id"] == self.next {
                assert!(answer["error"].is_null(), "{method}: {answer}");
                return answer["result"].clone();
            }
        }
    }

    /// The value of the JavaScript expression `js` (awaited when it is a promise).
    fn eval(&mut self, js: &str) -> Value {
        let r = self.call(
            "Runtime.evaluate",
            serde_json::json!({ "expression": js, "awaitPromise": true, "returnByValue": true }),
        );
        assert!(r["exceptionDetails"].is_null(), "{js}: {r}");
        r["result"]["value"].clone()
    }

    /// The page as PNG bytes, after half a second for the 3D panes to draw, also kept as
    /// `target/tmp/serve-screenshots/NAME`.
    fn screenshot(&mut self, name: &str) -> Vec<u8> {
        use base64::Engine as _;
        std::thread::sleep(std::time::Duration::from_millis(500));
        let shot = self.call(
            "Page.captureScreenshot",
            serde_json::json!({ "format": "png" }),
        );
        let png_bytes = base64::engine::general_purpose::STANDARD
            .decode(shot["data"].as_str().expect("data"))
            .expect("base64");
        let shots = Path::new(env!("CARGO_TARGET_TMPDIR")).join("serve-screenshots");
        std::fs::create_dir_all(&shots).expect("mkdir");
        std::fs::write(shots.join(name), &png_bytes).expect("writes");
        png_bytes
    }

    /// Waits up to `seconds` for `js` to be true.
    fn wait_for(&mut self, js: &str, seconds: u64) {
        let until = std::time::Instant::now() + std::time::Duration::from_secs(seconds);
        while self.eval(js) != Value::Bool(true) {
            assert!(
                std::time::Instant::now() < until,
                "timed out waiting for {js}"
            );
            std::thread::sleep(std::time::Duration::from_millis(200));
        }
    }
}

/// A fragment dropped on the page (as a user drags a file from the desktop): the results list
/// its source first, and the first result opened draws the query and the source side by side
/// with matched parts coloured, then overlaid (the fragment moved onto its source). The
/// screenshots are kept in `target/tmp/serve-screenshots/`. Skipped without Chromium.
#[test]
fn a_fragment_dropped_on_the_page_lists_its_source_first() {
    let Some(browser) = chromium() else {
        eprintln!("skipping the browser check: no chromium found (apt-get install chromium)");
        return;
    };
    let tmp = tempfile::tempdir().expect("tempdir");
    let (index, meshes) = collection(tmp.path(), &[Class::Octopus, Class::Mug, Class::Humanoid]);
    let server = serve(&index, &[]);
    let (source_name, source) = &meshes[1];
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let fragment =
        keycomp_fragment::cut_fragment(source, keycomp_fragment::PartialKind::Plane, 0.6, &mut rng)
            .expect("cuts");
    let text = String::from_utf8(off_bytes(&fragment.mesh)).expect("OFF is text");

    let mut page = Devtools::open(
        &browser,
        &tmp.path().join("profile"),
        &format!("{}/", server.base),
    );
    page.wait_for(
        "document.querySelectorAll('#shape-grid .card').length === 6",
        60,
    );
    page.eval(&format!(
        "(() => {{ const dt = new DataTransfer(); \
           dt.items.add(new File([{}], 'piece.off')); \
           document.getElementById('drop').dispatchEvent(new DragEvent('drop', \
             {{ dataTransfer: dt, bubbles: true, cancelable: true }})); return true; }})()",
        serde_json::to_string(&text).expect("JSON string")
    ));
    page.wait_for(
        "document.querySelectorAll('#result-grid .card').length > 0",
        120,
    );
    let first = page.eval("document.querySelector('#result-grid .card').title");
    let first = first.as_str().expect("a path");
    assert!(
        first.ends_with(&format!("{source_name}.off")),
        "first result {first}, not {source_name}"
    );
    page.eval("document.querySelector('#result-grid .card').click(), true");
    page.wait_for(
        "document.querySelectorAll('#view3d .pane[data-loaded=\"1\"]').length === 2",
        60,
    );
    let png_bytes = page.screenshot("dropped-fragment.png");
    let (width, px) = pixels(&png_bytes);
    both_panes_coloured(width, &px);
    // names are relative to the indexed folder, and the cards take the keyboard's focus
    let name = page.eval("document.querySelector('#result-grid .card div:last-child').textContent");
    assert!(
        !name.as_str().expect("text").contains('/'),
        "a result named {name}"
    );
    assert_eq!(
        page.eval("document.querySelector('#result-grid .card').tabIndex"),
        serde_json::json!(0)
    );
    // overlaid: the fragment moved onto its source by the result's transform, coloured by its
    // distance to it; most of it lies on it
    page.eval("document.getElementById('overlay').click(), true");
    page.wait_for(
        "document.querySelectorAll('#view3d .error').length > 0 || (document.querySelectorAll('#view3d .pane.wide[data-loaded=\"1\"]').length === 1 && document.getElementById('hover').textContent.includes('median distance'))",
        60,
    );
    let errors = page.eval(
        "Array.from(document.querySelectorAll('#view3d .error')).map(e => e.textContent).join('; ')",
    );
    assert_eq!(errors, serde_json::json!(""), "the overlay failed");
    let tip = page.eval("document.getElementById('hover').textContent");
    let tip = tip.as_str().expect("text");
    let median: f64 = tip
        .split("median distance ")
        .nth(1)
        .and_then(|t| t.split(' ').next())
        .and_then(|x| x.parse().ok())
        .expect("a median distance");
    assert!(median < 0.5, "{tip}");
    page.screenshot("overlaid-fragment.png");
}

/// The `keycomp query` processes the server `pid` is running (Linux: from `/proc`).
fn query_children(pid: u32) -> Vec<u32> {
    let Ok(dir) = std::fs::read_dir("/proc") else {
        return Vec::new();
    };
    dir.filter_map(|e| e.ok()?.file_name().to_str()?.parse::<u32>().ok())
        .filter(|p| {
            let stat = std::fs::read_to_string(format!("/proc/{p}/stat")).unwrap_or_default();
            // the parent is the 4th field, after the command in parentheses
            let parent = stat
                .rsplit_once(')')
                .and_then(|(_, rest)| rest.split_whitespace().nth(1)?.parse::<u32>().ok());
            parent == Some(pid)
        })
        .collect()
}

/// A query that outlives `--timeout` is answered 504 and its process stopped; a query whose
/// client goes away is stopped too; the server goes on answering.
#[test]
fn slow_and_abandoned_queries_are_stopped() {
    if !Path::new("/proc/self/stat").exists() {
        eprintln!("skipping: needs /proc to see the server's child processes");
        return;
    }
    let tmp = tempfile::tempdir().expect("tempdir");
    let (index, _) = collection(tmp.path(), &[Class::Mug]);
    let server = serve(&index, &["--timeout", "1"]);
    let pid = server._process.0.id();
    // a sphere of 655,362 vertices: seconds of analysis on any machine
    let big = off_bytes(&keycomp_mesh::synth::icosphere(8, 1.0));

    let t = std::time::Instant::now();
    let (status, e) = upload(&server, "/api/query", "sphere.off", &big);
    assert_eq!(status, 504, "{e}");
    assert!(
        e["error"].as_str().unwrap().contains("longer than 1 s"),
        "{e}"
    );
    assert!(t.elapsed().as_secs() < 30);
    std::thread::sleep(std::time::Duration::from_millis(300));
    assert_eq!(
        query_children(pid),
        Vec::<u32>::new(),
        "the timed-out query still runs"
    );

    // a client that goes away while its query runs
    let (body, kind) = multipart("sphere.off", &big);
    let addr = server.base.trim_start_matches("http://");
    let mut client = std::net::TcpStream::connect(addr).expect("connects");
    std::io::Write::write_all(
        &mut client,
        format!(
            "POST /api/query HTTP/1.1\r\nHost: {addr}\r\nContent-Type: {kind}\r\nContent-Length: {}\r\n\r\n",
            body.len()
        )
        .as_bytes(),
    )
    .expect("sends");
    std::io::Write::write_all(&mut client, &body).expect("sends");
    let wait = |running: bool, what: &str| {
        let until = std::time::Instant::now() + std::time::Duration::from_secs(20);
        while query_children(pid).is_empty() == running {
            assert!(std::time::Instant::now() < until, "{what}");
            std::thread::sleep(std::time::Duration::from_millis(50));
        }
    };
    wait(true, "the query never started");
    drop(client);
    wait(false, "the abandoned query still runs");
    assert_eq!(get(&server, "/api/index").0, 200);
}
