// The sc2jax viewer's page: polls the server for the current step, shows its pictures,
// and sends a person's clicks and keys (the server turns them into PySC2 calls).
"use strict";

const $ = (id) => document.getElementById(id);
const SPEEDS = [1, 2, 4, 8, 16, 32, 64];
const DEFAULT_LAYERS = ["screen/player_relative", "screen/unit_type", "screen/selected",
                        "minimap/player_relative"];
// Keys for functions, as in the game's grid layout where PySC2 has the function.
const KEYS = {
  a: ["Attack_screen", "Attack_minimap"], m: ["Move_screen", "Move_minimap"],
  p: ["Patrol_screen", "Patrol_minimap"], s: ["Stop_quick"], h: ["HoldPosition_quick"],
  g: ["Harvest_Gather_screen"], c: ["Harvest_Return_quick"], q: ["Train_Marine_quick"],
  e: ["Train_SCV_quick"], b: ["Build_Barracks_screen"], d: ["Build_SupplyDepot_screen"],
  r: ["Build_Refinery_screen"], y: ["Rally_Units_screen", "Rally_Workers_screen"],
};

let status = null;
let version = null;
let armed = null;  // A function waiting for its point: {id, name, args}.
const shown = new Set(DEFAULT_LAYERS);

function message(text) { $("message").textContent = text || ""; }

async function post(path, body) {
  const response = await fetch(path, {method: "POST", body: JSON.stringify(body)});
  const reply = await response.json();
  message(response.ok ? (reply.call ? "queued " + reply.call : "") : reply.error);
  return response.ok;
}

function keyOf(name) {
  for (const [key, names] of Object.entries(KEYS)) if (names.includes(name)) return key;
  return "";
}

function spatial(fn) {
  return fn.args.some((a) => a === "screen" || a === "minimap" || a === "screen2");
}

function defaults(fn, shift) {
  return fn.args.map((a) => [a === "queued" || a === "select_add" ? (shift ? 1 : 0) : 0]);
}

function choose(fn, shift) {
  if (spatial(fn)) { armed = fn; message(fn.name + ": click its target (Esc cancels)"); }
  else post("/api/act", {function: fn.id, arguments: defaults(fn, shift)});
  renderFunctions();
}

function renderFunctions() {
  const list = $("functions");
  list.replaceChildren(...status.available.map((fn) => {
    const item = document.createElement("li");
    const key = keyOf(fn.name);
    item.innerHTML = (key ? `<kbd>${key}</kbd> ` : "") + fn.name;
    item.dataset.name = fn.name;
    if (armed && armed.id === fn.id) item.className = "armed";
    item.onclick = (e) => choose(fn, e.shiftKey);
    return item;
  }));
}

function renderLayers() {
  const choice = $("layer-choice");
  if (!choice.childElementCount) {
    choice.replaceChildren(...status.layers.map((layer) => {
      const label = document.createElement("label");
      const box = document.createElement("input");
      box.type = "checkbox";
      box.checked = shown.has(layer.name);
      box.onchange = () => { box.checked ? shown.add(layer.name) : shown.delete(layer.name);
                             version = null; };
      label.append(box, " " + layer.name);
      return label;
    }));
  }
  $("layers").replaceChildren(...status.layers.filter((l) => shown.has(l.name)).map((l) => {
    const box = document.createElement("div");
    box.className = "layer";
    const legend = l.scale ?
      `<i class="heat"></i>0 to ${l.scale[1]} (now up to ${l.scale[2]})` :
      (l.legend || []).map(([, rgb, label]) =>
        `<i style="background: rgb(${rgb.join(",")})"></i>${label}`).join("");
    box.innerHTML = `<h2>${l.name}</h2><img alt="${l.name}" src="/api/image/layer/` +
      `${l.name}.png?v=${status.version}"><div class="legend">${legend}</div>`;
    return box;
  }));
}

async function poll() {
  try {
    const response = await fetch("/api/status");
    status = await response.json();
  } catch (e) {
    message("the server is not answering");
    return setTimeout(poll, 1000);
  }
  $("title").textContent = `sc2jax · ${status.map} · ${status.mode}` +
    (status.mode === "play" ? "" : ` (${status.agent})`);
  $("numbers").textContent = (status.episode ? `episode ${status.episode} · ` : "") +
    `step ${status.step} · ` +
    `game loop ${status.game_loop} · ` +
    (typeof status.score === "number" ? `score ${status.score}` : status.score) +
    (status.last_scores && status.last_scores.length ?
      ` · last scores ${status.last_scores.join(", ")}` : "");
  $("pause").textContent = status.paused ? "play" : "pause";
  $("speed-value").textContent = `${status.speed} steps/s`;
  if (status.error) message(status.error);
  if (status.length !== undefined) {  // A recording: playback or replay.
    $("timeline-box").hidden = false;
    $("timeline").max = status.length - 1;
    if (document.activeElement !== $("timeline")) $("timeline").value = status.step;
  }
  if (status.version !== version) {
    version = status.version;
    $("view").src = `/api/image/view.png?v=${version}`;
    $("minimap").src = `/api/image/minimap.png?v=${version}`;
    $("last-call").textContent = status.last_call || "—";
    renderFunctions();
    renderLayers();
  }
  setTimeout(poll, 120);
}

// Mouse on the view and the minimap, in the pictures' own pixels. Their sizes are kept
// from their last load: while the next step's picture loads, naturalWidth can read 0.
const natural = {};
for (const id of ["view", "minimap"]) {
  $(id).addEventListener("load", () => {
    natural[id] = [$(id).naturalWidth, $(id).naturalHeight];
  });
}
function at(img, e) {
  const box = img.getBoundingClientRect();
  const [width, height] = natural[img.id] || [img.naturalWidth, img.naturalHeight];
  return [(e.clientX - box.left) * width / box.width,
          (e.clientY - box.top) * height / box.height];
}

let dragStart = null;
$("view").addEventListener("mousedown", (e) => {
  if (e.button !== 0) return;
  dragStart = {point: at($("view"), e), client: [e.clientX, e.clientY]};
  e.preventDefault();
});
window.addEventListener("mousemove", (e) => {
  if (!dragStart) return;
  const box = $("view").getBoundingClientRect();
  const [x0, y0] = dragStart.client;
  Object.assign($("drag").style, {
    display: "block", left: `${Math.min(x0, e.clientX) - box.left}px`,
    top: `${Math.min(y0, e.clientY) - box.top}px`,
    width: `${Math.abs(e.clientX - x0)}px`, height: `${Math.abs(e.clientY - y0)}px`});
});
window.addEventListener("mouseup", (e) => {
  if (!dragStart || e.button !== 0) return;
  const [x, y] = dragStart.point;
  const [x2, y2] = at($("view"), e);
  const moved = Math.hypot(e.clientX - dragStart.client[0], e.clientY - dragStart.client[1]);
  dragStart = null;
  $("drag").style.display = "none";
  if (armed) {
    post("/api/click", {pane: "view", kind: "point", function: armed.id, x, y,
                        shift: e.shiftKey});
    armed = null;
    renderFunctions();
  } else if (moved > 4) {
    post("/api/click", {pane: "view", kind: "rect", x, y, x2, y2, shift: e.shiftKey});
  } else {
    post("/api/click", {pane: "view", kind: "select", x, y, shift: e.shiftKey});
  }
});
$("view").addEventListener("contextmenu", (e) => {
  e.preventDefault();
  const [x, y] = at($("view"), e);
  post("/api/click", {pane: "view", kind: "smart", x, y, shift: e.shiftKey});
});
$("minimap").addEventListener("click", (e) => {
  const [x, y] = at($("minimap"), e);
  if (armed) {
    post("/api/click", {pane: "minimap", kind: "point", function: armed.id, x, y,
                        shift: e.shiftKey});
    armed = null;
    renderFunctions();
  } else {
    post("/api/click", {pane: "minimap", kind: "select", x, y});
  }
});
$("minimap").addEventListener("contextmenu", (e) => {
  e.preventDefault();
  const [x, y] = at($("minimap"), e);
  post("/api/click", {pane: "minimap", kind: "smart", x, y, shift: e.shiftKey});
});

// Keys.
window.addEventListener("keydown", (e) => {
  if (!status || e.target.tagName === "INPUT") return;
  const byName = (name) => status.available.find((fn) => fn.name === name);
  if (e.key === " ") { post("/api/control", {paused: !status.paused}); }
  else if (e.key === ".") { post("/api/control", {step: 1}); }
  else if (e.key === "Escape") { armed = null; message(""); renderFunctions(); }
  else if (e.key === "F1" && byName("select_idle_worker")) {
    post("/api/act", {function: "select_idle_worker", arguments: [[e.shiftKey ? 1 : 0]]});
  } else if (e.key === "F2" && byName("select_army")) {
    post("/api/act", {function: "select_army", arguments: [[e.shiftKey ? 1 : 0]]});
  } else if (/^[0-9]$/.test(e.key)) {
    // PySC2's control_group_act: 0 recall, 1 set, 2 append.
    const act = e.ctrlKey ? 1 : e.shiftKey ? 2 : 0;
    post("/api/act", {function: "select_control_group",
                      arguments: [[act], [Number(e.key)]]});
  } else if (e.key === "r" && e.ctrlKey) { post("/api/control", {reset: true}); }
  else {
    const names = KEYS[e.key.toLowerCase()] || [];
    const fn = names.map(byName).find(Boolean);
    if (!fn) return;
    choose(fn, e.shiftKey);
  }
  e.preventDefault();
});

$("pause").onclick = () => post("/api/control", {paused: !status.paused});
$("step").onclick = () => post("/api/control", {step: 1});
$("reset").onclick = () => post("/api/control", {reset: true});
$("speed").oninput = () => post("/api/control", {speed: SPEEDS[$("speed").value]});
$("timeline").oninput = () => post("/api/control", {seek: Number($("timeline").value)});
poll();
