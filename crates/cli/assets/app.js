// keycomp serve: the collection as a grid, search by example, results and a 3D view of a shape
// with its matched parts coloured (three.js). Talks to the JSON API of the same server.
"use strict";

const $ = (id) => document.getElementById(id);
const PAGE = 48;
let offset = 0;

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
  $("info").textContent = `${info.dir} · ${info.shapes} shapes · ${measure}` +
    (p.surface ? " · canonical surfaces" : "");
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
      el("img", { src: `/api/shapes/${s.id}/thumb.png`, alt: s.path, loading: "lazy" }),
      el("div", { textContent: s.path }),
      el("div", { className: "note", textContent: `${s.vertices} vertices, ${s.parts} parts` }),
      similar);
    card.onclick = () => { location.hash = `view=${s.id}`; };
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
      el("img", { src: id === undefined ? "" : `/api/shapes/${id}/thumb.png`, alt: hit.path }),
      el("div", {}, el("span", { className: "score", textContent: `#${hit.rank} ${hit.score.toFixed(3)}` }),
        el("span", { className: "note", textContent: verified })),
      el("div", { textContent: hit.path }));
    if (id !== undefined) card.onclick = () => view(id, hit.path, hit, answer.session, answer.query);
    grid.append(card);
  }
}

// The palette as byte triples, to tell which pair a hovered vertex belongs to.
const PALETTE = Array.from({ length: 64 }, (_, k) => distinct(k).slice(4, -1).split(",").map(Number));

// One 3D pane in `box`: the GLB at `url`, orbit controls, and `hover(k)` called with the
// palette index of the coloured part under the pointer (-1 for none).
function pane(box, url, label, hover) {
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
  let mesh = null;
  new THREE.GLTFLoader().load(url, (gltf) => {
    gltf.scene.traverse((o) => {
      if (o.isMesh) {
        o.geometry.computeVertexNormals();
        o.material = new THREE.MeshLambertMaterial({ vertexColors: THREE.VertexColors, side: THREE.DoubleSide });
        mesh = o;
      }
    });
    const bounds = new THREE.Box3().setFromObject(gltf.scene);
    const centre = bounds.getCenter(new THREE.Vector3());
    const radius = bounds.getSize(new THREE.Vector3()).length() / 2 || 1;
    camera.position.copy(centre).add(new THREE.Vector3(0.4, 0.3, 1).normalize().multiplyScalar(radius * 2.8));
    camera.near = radius / 100; camera.far = radius * 100; camera.updateProjectionMatrix();
    controls.target.copy(centre);
    controls.update();
    scene.add(gltf.scene);
    box.dataset.loaded = "1";
  }, undefined, (e) => box.append(el("div", { className: "error", textContent: String(e.message || e) })));
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
  return { render, dispose: () => renderer.dispose() };
}

// The 3D view of an indexed shape; with a hit, the query `queryName` (when the server kept it,
// as `session`) and the shape side by side, the k-th matched pair in the palette's k-th colour on both.
let panes = [];
function view(id, path, hit, session, queryName) {
  $("viewer").hidden = false;
  $("viewer-title").textContent = path + (hit ? ` · score ${hit.score.toFixed(3)}` : "");
  const legend = $("legend");
  legend.replaceChildren();
  const box = $("view3d");
  box.replaceChildren();
  for (const p of panes) p.dispose();
  panes = [];
  const tip = $("hover");
  const hover = (k) => {
    if (!hit || k < 0 || k >= hit.matches.length) { tip.textContent = ""; return; }
    const m = hit.matches[k];
    tip.textContent = `pair ${k + 1}: query part ${m.query_component} ↔ part ${m.target_component}, distance ${m.distance.toFixed(3)}`;
  };
  let parts = "";
  if (hit) {
    parts = "?parts=" + hit.matches.map((m) => m.target_component).join(",");
    hit.matches.forEach((m, k) => legend.append(el("li", {},
      el("span", { className: "sw", style: `background:${distinct(k)}` }),
      `query part ${m.query_component} ↔ part ${m.target_component}: distance ${m.distance.toFixed(3)}`)));
  }
  // both panes laid out before either renderer takes its size
  const withQuery = hit && session !== undefined && session !== null;
  const q = el("div", { className: "pane" }), r = el("div", { className: "pane" });
  if (withQuery) box.append(q);
  box.append(r);
  if (withQuery) {
    const queryParts = hit.matches.map((m) => m.query_component).join(",");
    panes.push(pane(q, `/api/queries/${session}/mesh.glb?hypothesis=${hit.hypothesis}&parts=${queryParts}`, `query: ${queryName}`, hover));
  }
  panes.push(pane(r, `/api/shapes/${id}/mesh.glb${parts}`, path, hover));
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
