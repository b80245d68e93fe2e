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
  $("info").textContent = info.dir + " · " + info.shapes + " shapes";
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
    showResults(answer);
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
  // results name shapes by path: find their ids
  const page = await api(`/api/shapes?limit=500&filter=`);
  const byPath = new Map(page.shapes.map((s) => [s.path, s.id]));
  for (const hit of answer.results) {
    let id = byPath.get(hit.path);
    if (id === undefined) {
      const found = await api(`/api/shapes?limit=500&filter=${encodeURIComponent(hit.path)}`);
      const s = found.shapes.find((s) => s.path === hit.path);
      id = s && s.id;
    }
    const verified = hit.verified == null ? "" : `, verified ${(100 * hit.verified).toFixed(0)} %`;
    const card = el("div", { className: "card result", title: hit.path },
      el("img", { src: id === undefined ? "" : `/api/shapes/${id}/thumb.png`, alt: hit.path }),
      el("div", {}, el("span", { className: "score", textContent: `#${hit.rank} ${hit.score.toFixed(3)}` }),
        el("span", { className: "note", textContent: verified })),
      el("div", { textContent: hit.path }));
    if (id !== undefined) card.onclick = () => view(id, hit.path, hit);
    grid.append(card);
  }
}

// The 3D view of an indexed shape; with a hit, its matched parts in the palette's order.
let renderer = null;
async function view(id, path, hit) {
  $("viewer").hidden = false;
  $("viewer-title").textContent = path + (hit ? ` · score ${hit.score.toFixed(3)}` : "");
  const legend = $("legend");
  legend.replaceChildren();
  let parts = "";
  if (hit) {
    parts = "?parts=" + hit.matches.map((m) => m.target_component).join(",");
    hit.matches.forEach((m, k) => legend.append(el("li", {},
      el("span", { className: "sw", style: `background:${distinct(k)}` }),
      `query part ${m.query_component} ↔ part ${m.target_component}: distance ${m.distance.toFixed(3)}`)));
  }
  const box = $("view3d");
  box.replaceChildren();
  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0xf4f4f4);
  scene.add(new THREE.HemisphereLight(0xffffff, 0x666666, 0.9));
  const light = new THREE.DirectionalLight(0xffffff, 0.6);
  light.position.set(1, 2, 3);
  scene.add(light);
  const camera = new THREE.PerspectiveCamera(40, box.clientWidth / Math.max(1, box.clientHeight), 0.001, 1000);
  if (!renderer) renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
  renderer.setSize(box.clientWidth, box.clientHeight);
  box.append(renderer.domElement);
  const controls = new THREE.OrbitControls(camera, renderer.domElement);
  new THREE.GLTFLoader().load(`/api/shapes/${id}/mesh.glb${parts}`, (gltf) => {
    gltf.scene.traverse((o) => {
      if (o.isMesh) {
        o.geometry.computeVertexNormals();
        o.material = new THREE.MeshLambertMaterial({ vertexColors: THREE.VertexColors, side: THREE.DoubleSide });
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
  }, undefined, (e) => { legend.append(el("li", { className: "error", textContent: String(e.message || e) })); });
  box.dataset.loaded = "";
  (function animate() {
    if ($("viewer").hidden) return;
    requestAnimationFrame(animate);
    renderer.render(scene, camera);
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
// `#view=ID` opens shape ID in the 3D view (a link to a shape).
function fromHash() {
  const m = /^#view=(\d+)$/.exec(location.hash);
  if (m) api(`/api/shapes/${m[1]}`).then((s) => view(s.id, s.path, null)).catch(() => {});
}
window.onhashchange = fromHash;
loadInfo().then(loadPage).then(fromHash).catch((e) => { $("info").textContent = e.message; $("info").className = "error"; });
