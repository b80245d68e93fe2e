// keycomp serve: the collection as a grid, search by example, results and a 3D view of a shape
// with its matched parts coloured (three.js). Talks to the JSON API of the same server.
"use strict";

const $ = (id) => document.getElementById(id);
const PAGE = 48;
let offset = 0;
// the folder every indexed path lies under: shapes are named from it (the full path in titles)
let root = "";
const named = (path) => (root && path.startsWith(root) ? path.slice(root.length) : path);

// A card opens with a click, or with Enter or Space once it has the keyboard's focus.
function activate(card, open) {
  card.tabIndex = 0;
  card.onclick = open;
  card.onkeydown = (ev) => {
    if (ev.key === "Enter" || ev.key === " ") { ev.preventDefault(); open(); }
  };
}

// The palette of `keycomp` (colors::distinct): golden-angle hue steps.
function distinct(i) {
  const h = (i * 137.507764) % 360, s = 0.75, v = i % 2 === 0 ? 0.95 : 0.75;
  const c = v * s, x = c * (1 - Math.abs(((h / 60) % 2) - 1)), m = v - c;
  const rgb = [[c, x, 0], [x, c, 0], [0, c, x], [0, x, c], [x, 0, c], [c, 0, x]][Math.min(5, Math.floor(h / 60))];
  return "rgb(" + rgb.map((u) => Math.round((u + m) * 255)).join(",") + ")";
}

function el(tag, attrs, ...children) {
  const e = document.createElement(tag);
  Object.assign(e, attrs || {});
  for (const c of children) e.append(c);
  return e;
}

async function api(url, options) {
  const r = await fetch(url, options);
  const body = await r.json().catch(() => ({ error: r.statusText }));
  if (!r.ok) throw new Error(body.error || r.statusText);
  return body;
}

async function loadInfo() {
  const info = await api("/api/index");
  // how the index measures shapes (queries are analysed the same way)
  const p = info.profile || {}, units = (p.describe && p.describe.units) || {};
  const measure = units.kind === "file" ? `file units (length ${units.length})` : "scale-free";
  root = info.root || "";
  $("info").textContent = `${info.dir} · ${info.shapes} shapes · ${measure}` +
    (p.surface ? " · canonical surfaces" : "") + (root ? ` · under ${root}` : "");
}

async function loadPage() {
  const filter = encodeURIComponent($("filter").value);
  const page = await api(`/api/shapes?offset=${offset}&limit=${PAGE}&filter=${filter}`);
  const grid = $("shape-grid");
  grid.replaceChildren();
  for (const s of page.shapes) {
    const similar = el("button", { textContent: "find similar" });
    similar.onclick = (ev) => { ev.stopPropagation(); search(`/api/shapes/${s.id}/similar`, null, s.path); };
    const card = el("div", { className: "card", title: s.path },
      el("img", { src: `/api/shapes/${s.id}/thumb.png`, alt: named(s.path), loading: "lazy" }),
      el("div", { textContent: named(s.path) }),
      el("div", { className: "note", textContent: `${s.vertices} vertices, ${s.parts} parts` }),
      similar);
    activate(card, () => { location.hash = `view=${s.id}`; });
    grid.append(card);
  }
  const last = Math.min(page.matched, offset + page.shapes.length);
  $("page").textContent = page.matched ? `${offset + 1}–${last} of ${page.matched}` : "no shape matches";
  $("prev").disabled = offset === 0;
  $("next").disabled = last >= page.matched;
}

// Runs a query (an upload or an indexed shape) and shows its results as a grid.
async function search(url, file, name) {
  const k = $("k").value, verify = $("verify").value;
  let body;
  if (file) { body = new FormData(); body.append("file", file, file.name); }
  const status = $("status");
  const start = performance.now();
  const tick = setInterval(() => {
    status.textContent = `analysing ${name}… ${((performance.now() - start) / 1000).toFixed(0)} s`;
  }, 250);
  status.className = "note";
  status.textContent = `analysing ${name}…`;
  try {
    const answer = await api(`${url}?k=${k}&verify=${verify}`, { method: "POST", body });
    status.textContent = `${name}: ${answer.components} parts, ` +
      `${answer.results.length} results in ${((performance.now() - start) / 1000).toFixed(1)} s`;
    await showResults(answer);
    return answer;
  } catch (e) {
    status.className = "error";
    status.textContent = e.message;
  } finally {
    clearInterval(tick);
  }
}

async function showResults(answer) {
  $("results").hidden = false;
  $("results-title").textContent = `Results for ${answer.query}`;
  const grid = $("result-grid");
  grid.replaceChildren();
  for (const hit of answer.results) {
    const id = hit.id == null ? undefined : hit.id;
    const verified = hit.verified == null ? "" : `, verified ${(100 * hit.verified).toFixed(0)} %`;
    const card = el("div", { className: "card result", title: hit.path },
      el("img", { src: id === undefined ? "" : `/api/shapes/${id}/thumb.png`, alt: named(hit.path) }),
      el("div", {}, el("span", { className: "score", textContent: `#${hit.rank} ${hit.score.toFixed(3)}` }),
        el("span", { className: "note", textContent: verified })),
      el("div", { textContent: named(hit.path) }));
    if (id !== undefined) activate(card, () => view(id, hit.path, hit, answer.session, answer.query, answer.components));
    grid.append(card);
  }
}

// The palette as byte triples, to tell which pair a hovered vertex belongs to.
const PALETTE = Array.from({ length: 64 }, (_, k) => distinct(k).slice(4, -1).split(",").map(Number));

// A lit scene in `box` under `label`, its camera with orbit controls and its renderer;
// `frame(object)` points the camera at `object` from 1.4 of its diagonal away (and returns the
// diagonal), `fail(e)` shows an error in the box, `handle` is what `view` renders and disposes.
function stage(box, label) {
  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0xf4f4f4);
  scene.add(new THREE.HemisphereLight(0xffffff, 0x666666, 0.9));
  const light = new THREE.DirectionalLight(0xffffff, 0.6);
  light.position.set(1, 2, 3);
  scene.add(light);
  const width = Math.max(1, box.clientWidth), height = Math.max(1, box.clientHeight);
  const camera = new THREE.PerspectiveCamera(40, width / height, 0.001, 1000);
  const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
  renderer.setSize(width, height);
  box.append(el("div", { className: "label", textContent: label }), renderer.domElement);
  const controls = new THREE.OrbitControls(camera, renderer.domElement);
  const frame = (object) => {
    const bounds = new THREE.Box3().setFromObject(object);
    const centre = bounds.getCenter(new THREE.Vector3());
    const diag = bounds.getSize(new THREE.Vector3()).length() || 1;
    camera.position.copy(centre).add(new THREE.Vector3(0.4, 0.3, 1).normalize().multiplyScalar(diag * 1.4));
    camera.near = diag / 200; camera.far = diag * 50; camera.updateProjectionMatrix();
    controls.target.copy(centre);
    controls.update();
    return diag;
  };
  const fail = (e) => box.append(el("div", { className: "error", textContent: String(e.message || e) }));
  const render = () => {
    const w = Math.max(1, box.clientWidth), h = Math.max(1, box.clientHeight);
    const size = renderer.getSize(new THREE.Vector2());
    if (size.x !== w || size.y !== h) {
      renderer.setSize(w, h);
      camera.aspect = w / h;
      camera.updateProjectionMatrix();
    }
    renderer.render(scene, camera);
  };
  return { scene, camera, renderer, frame, fail, handle: { render, dispose: () => renderer.dispose() } };
}

// One 3D pane in `box`: the GLB at `url`, orbit controls, and `hover(k)` called with the
// palette index of the coloured part under the pointer (-1 for none).
function pane(box, url, label, hover) {
  const { scene, camera, renderer, frame, fail, handle } = stage(box, label);
  let mesh = null;
  new THREE.GLTFLoader().load(url, (gltf) => {
    gltf.scene.traverse((o) => {
      if (o.isMesh) {
        o.geometry.computeVertexNormals();
        o.material = new THREE.MeshLambertMaterial({ vertexColors: THREE.VertexColors, side: THREE.DoubleSide });
        mesh = o;
      }
    });
    frame(gltf.scene);
    scene.add(gltf.scene);
    box.dataset.loaded = "1";
  }, undefined, fail);
  const ray = new THREE.Raycaster();
  renderer.domElement.onmousemove = (ev) => {
    if (!mesh) return;
    const r = renderer.domElement.getBoundingClientRect();
    ray.setFromCamera(new THREE.Vector2(((ev.clientX - r.left) / r.width) * 2 - 1, -((ev.clientY - r.top) / r.height) * 2 + 1), camera);
    const hit = ray.intersectObject(mesh)[0];
    const colours = mesh.geometry.getAttribute("color");
    if (!hit || !colours) { hover(-1); return; }
    const v = hit.face.a;
    const bytes = colours.array instanceof Uint8Array;
    const c = [colours.getX(v), colours.getY(v), colours.getZ(v)].map((x) => (bytes ? x : Math.round(x * 255)));
    hover(PALETTE.findIndex((p) => p[0] === c[0] && p[1] === c[1] && p[2] === c[2]));
  };
  renderer.domElement.onmouseleave = () => hover(-1);
  return handle;
}

// Colour of a distance d relative to `far`: blue on the surface, through green and yellow,
// red at `far` and beyond.
function heat(d, far) {
  const t = Math.min(1, Math.max(0, d / far));
  const stops = [[0.1, 0.3, 0.9], [0.1, 0.75, 0.3], [0.95, 0.85, 0.1], [0.9, 0.15, 0.1]];
  const x = t * (stops.length - 1), i = Math.min(stops.length - 2, Math.floor(x)), f = x - i;
  return stops[i].map((a, k) => a + (stops[i + 1][k] - a) * f);
}

// Distance from each point of `query` (a flat xyz array) to the nearest of `target`'s, through
// a uniform grid of cells of side `cell` (the nearest within the 27 cells around, else `far`).
function nearestDistances(query, target, cell, far) {
  const key = (x, y, z) => `${Math.floor(x / cell)},${Math.floor(y / cell)},${Math.floor(z / cell)}`;
  const grid = new Map();
  for (let i = 0; i < target.length; i += 3) {
    const k = key(target[i], target[i + 1], target[i + 2]);
    if (!grid.has(k)) grid.set(k, []);
    grid.get(k).push(i);
  }
  const out = new Float32Array(query.length / 3);
  for (let q = 0; q < query.length; q += 3) {
    const [x, y, z] = [query[q], query[q + 1], query[q + 2]];
    const [cx, cy, cz] = [Math.floor(x / cell), Math.floor(y / cell), Math.floor(z / cell)];
    let best = far * far;
    for (let dx = -1; dx <= 1; dx++) for (let dy = -1; dy <= 1; dy++) for (let dz = -1; dz <= 1; dz++) {
      for (const i of grid.get(`${cx + dx},${cy + dy},${cz + dz}`) || []) {
        const d = (target[i] - x) ** 2 + (target[i + 1] - y) ** 2 + (target[i + 2] - z) ** 2;
        if (d < best) best = d;
      }
    }
    out[q / 3] = Math.sqrt(best);
  }
  return out;
}

// The query laid over the shape in the shape's frame: the shape at `shapeUrl` in grey, the
// query at `queryUrl` moved by `matrix` (row-major 4×4, the result's transform), each of its
// vertices coloured by its distance to the shape (0 to 2 % of the shape's diagonal).
function overlayPane(box, shapeUrl, queryUrl, matrix, label, done) {
  const { scene, frame, fail, handle } = stage(box, label);
  const loader = new THREE.GLTFLoader();
  const meshOf = (gltf) => { let m = null; gltf.scene.traverse((o) => { if (o.isMesh) m = o; }); return m; };
  // an exception in a loader's callback would otherwise vanish: it is shown as the pane's error
  const guarded = (f) => (arg) => { try { f(arg); } catch (e) { fail(e); } };
  loader.load(shapeUrl, guarded((shapeGltf) => {
    const shape = meshOf(shapeGltf);
    if (!shape) { fail("the shape has no mesh"); return; }
    shape.geometry.computeVertexNormals();
    shape.material = new THREE.MeshLambertMaterial({ color: 0xbbbbbb, side: THREE.DoubleSide, transparent: true, opacity: 0.55 });
    scene.add(shapeGltf.scene);
    const diag = frame(shapeGltf.scene);
    loader.load(queryUrl, guarded((queryGltf) => {
      const query = meshOf(queryGltf);
      if (!query) { fail("the query has no mesh"); return; }
      const m = new THREE.Matrix4();
      m.set(...matrix.flat());
      query.geometry.applyMatrix(m); // three.js r111 (applyMatrix4 from r115)
      query.geometry.computeVertexNormals();
      const far = 0.02 * diag;
      const d = nearestDistances(query.geometry.getAttribute("position").array,
        shape.geometry.getAttribute("position").array, far, far);
      const colours = new Float32Array(d.length * 3);
      d.forEach((x, i) => colours.set(heat(x, far), 3 * i));
      query.geometry.setAttribute("color", new THREE.BufferAttribute(colours, 3));
      query.material = new THREE.MeshLambertMaterial({ vertexColors: THREE.VertexColors, side: THREE.DoubleSide });
      scene.add(queryGltf.scene);
      box.dataset.loaded = "1";
      const sorted = Array.from(d).sort((a, b) => a - b);
      done(sorted[Math.floor(sorted.length / 2)] / diag);
    }), undefined, fail);
  }), undefined, fail);
  return handle;
}

// The 3D view of an indexed shape; with a hit, the query `queryName` (when the server kept it,
// as `session`) and the shape side by side, the k-th matched pair in the palette's k-th colour
// on both, or (the toggle, when the hit has a transform) the query overlaid on the shape.
let panes = [];
let overlaid = false;
function view(id, path, hit, session, queryName, queryParts) {
  $("viewer").hidden = false;
  $("viewer-title").textContent = named(path) + (hit ? ` · score ${hit.score.toFixed(3)}` : "");
  const legend = $("legend");
  legend.replaceChildren();
  const box = $("view3d");
  box.replaceChildren();
  for (const p of panes) p.dispose();
  panes = [];
  const tip = $("hover");
  tip.textContent = "";
  const hover = (k) => {
    if (!hit || k < 0 || k >= hit.matches.length) { tip.textContent = ""; return; }
    const m = hit.matches[k];
    tip.textContent = `pair ${k + 1}: query part ${m.query_component} ↔ part ${m.target_component}, distance ${m.distance.toFixed(3)}`;
  };
  const withQuery = hit && session !== undefined && session !== null;
  const toggle = $("overlay");
  toggle.hidden = !(withQuery && hit.transform);
  toggle.textContent = overlaid ? "side by side" : "overlaid";
  toggle.onclick = () => { overlaid = !overlaid; view(id, path, hit, session, queryName, queryParts); };
  const queryUrl = withQuery ? `/api/queries/${session}/mesh.glb?hypothesis=${hit.hypothesis}` : "";
  if (withQuery && hit.transform && overlaid) {
    const t = hit.transform;
    const q = el("div", { className: "pane wide" });
    box.append(q);
    panes.push(overlayPane(q, `/api/shapes/${id}/mesh.glb`, queryUrl, t.matrix,
      `query ${queryName} on ${named(path)}`, (median) => {
        tip.textContent = `query on the shape: median distance ${(100 * median).toFixed(2)} % of its diagonal` +
          (t.rms == null ? "" : `, RMS after refinement ${t.rms.toPrecision(3)}`) +
          `, scale ${t.scale.toPrecision(4)}, verified ${(100 * t.verified).toFixed(0)} %`;
      }));
    legend.append(el("li", {}, el("span", { className: "sw", style: "background:rgb(26,77,230)" }), "on the shape"),
      el("li", {}, el("span", { className: "sw", style: "background:rgb(230,38,26)" }), "2 % of its diagonal away or more"));
  } else {
    let parts = "";
    if (hit) {
      parts = "?parts=" + hit.matches.map((m) => m.target_component).join(",");
      if (queryParts != null) {
        legend.append(el("li", { className: "note" },
          `the query: ${queryParts} parts, ${hit.matches.length} of them matched (scale hypothesis ${hit.hypothesis})`));
      }
      hit.matches.forEach((m, k) => legend.append(el("li", {},
        el("span", { className: "sw", style: `background:${distinct(k)}` }),
        `query part ${m.query_component} ↔ part ${m.target_component}: distance ${m.distance.toFixed(3)}`)));
    }
    // both panes laid out before either renderer takes its size
    const q = el("div", { className: "pane" }), r = el("div", { className: "pane" });
    if (withQuery) box.append(q);
    box.append(r);
    if (withQuery) {
      const matched = hit.matches.map((m) => m.query_component).join(",");
      panes.push(pane(q, `${queryUrl}&parts=${matched}`, `query: ${queryName}`, hover));
    }
    panes.push(pane(r, `/api/shapes/${id}/mesh.glb${parts}`, named(path), hover));
  }
  (function animate() {
    if ($("viewer").hidden) return;
    requestAnimationFrame(animate);
    for (const p of panes) p.render();
  })();
}

$("close").onclick = () => { $("viewer").hidden = true; history.replaceState(null, "", location.pathname); };
$("prev").onclick = () => { offset = Math.max(0, offset - PAGE); loadPage(); };
$("next").onclick = () => { offset += PAGE; loadPage(); };
$("filter").oninput = () => { offset = 0; loadPage(); };
$("file").onchange = (e) => { const f = e.target.files[0]; if (f) search("/api/query", f, f.name); };
const drop = $("drop");
drop.ondragover = (e) => { e.preventDefault(); drop.classList.add("over"); };
drop.ondragleave = () => drop.classList.remove("over");
drop.ondrop = (e) => {
  e.preventDefault();
  drop.classList.remove("over");
  const f = e.dataTransfer.files[0];
  if (f) search("/api/query", f, f.name);
};
// `#view=ID` opens shape ID in the 3D view (a link to a shape); `#similar=ID` ranks the
// collection against shape ID, and with `&open=R` opens result R beside the query.
function fromHash() {
  const m = /^#view=(\d+)$/.exec(location.hash);
  if (m) api(`/api/shapes/${m[1]}`).then((s) => view(s.id, s.path, null, null)).catch(() => {});
  const q = /^#similar=(\d+)(?:&open=(\d+))?$/.exec(location.hash);
  if (q) {
    api(`/api/shapes/${q[1]}`)
      .then((s) => search(`/api/shapes/${s.id}/similar`, null, s.path))
      .then(() => {
        const card = document.querySelectorAll("#result-grid .card")[Number(q[2] || 0) - 1];
        if (card) card.click();
      })
      .catch(() => {});
  }
}
window.onhashchange = fromHash;
loadInfo().then(loadPage).then(fromHash).catch((e) => { $("info").textContent = e.message; $("info").className = "error"; });
