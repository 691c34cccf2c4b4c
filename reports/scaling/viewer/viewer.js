// The comparison viewer of an mcd report (mcd/reporting/viewer.py; docs/benchmark.md "Viewer").
// Plain script, no library, nothing from the network. window.MCD_VIEWER (data.js) holds, per scene and frame,
// the pictures (colour at each exposure stop, FLIP error maps, the full method's maps) and the metrics.
// Zoom and pan are one state (zoom over the fitted size, the picture point at each view's centre) that every
// view draws, so all pictures stay in sync whatever their view's size.
"use strict";
(function () {
  const D = window.MCD_VIEWER;
  const $ = (id) => document.getElementById(id);
  if (!D || !Array.isArray(D.frames) || D.frames.length === 0) {
    throw new Error("data.js holds no frames: regenerate the report with python -m mcd.report");
  }
  const MAX_ZOOM = 64;
  const state = { frame: 0, stop: Math.max(0, D.stops.indexOf(0)), left: "noisy", right: "reference",
                  wipe: 0.5, zoom: 1, cx: 0.5, cy: 0.5 };
  let views = [];
  let pictures = new Map();

  const frame = () => D.frames[state.frame];
  const fmt = { psnr: (v) => v.toFixed(2), ssim: (v) => v.toFixed(4), rmse: (v) => v.toPrecision(4),
                flip: (v) => v.toFixed(4) };
  const label = { psnr: "PSNR (dB)", ssim: "SSIM", rmse: "rMSE", flip: "FLIP" };
  const higherIsBetter = { psnr: true, ssim: true, rmse: false, flip: false };
  const show = (key, v) => (v === null || v === undefined ? "–" : fmt[key](v));

  // Every picture of the frame that the wipe can show: id -> {title, src()}.
  function collect(f) {
    const all = new Map();
    for (const im of f.images) {
      all.set(im.key, { title: im.title, src: () => im.stops[state.stop] });
      if (im.flip) all.set(im.key + ":flip", { title: "FLIP error of " + im.title, src: () => im.flip.src });
    }
    for (const m of f.maps) all.set(m.key, { title: m.title, src: () => m.src });
    return all;
  }

  function makeImg(id) {
    const img = document.createElement("img");
    img.draggable = false;
    img.alt = pictures.get(id).title;
    img.dataset.picture = id;
    img.src = pictures.get(id).src();
    return img;
  }

  // A view: a clipped box whose stage holds picture(s) at the frame's pixel size, moved by one transform.
  function makeView(el, ids) {
    el.textContent = "";
    const stage = document.createElement("div");
    stage.className = "stage";
    stage.style.width = frame().width + "px";
    stage.style.height = frame().height + "px";
    const imgs = ids.map(makeImg);
    imgs.forEach((img) => stage.appendChild(img));
    el.appendChild(stage);
    const view = { el, stage, imgs, ids, s: 1, tx: 0 };
    attach(view);
    views.push(view);
    return view;
  }

  function geometry(view) {
    const f = frame();
    const W = view.el.clientWidth, H = view.el.clientHeight;
    const s = Math.min(W / f.width, H / f.height) * state.zoom;
    return { W, H, s, tx: W / 2 - state.cx * f.width * s, ty: H / 2 - state.cy * f.height * s };
  }

  function draw() {
    const f = frame();
    for (const view of views) {
      const g = geometry(view);
      view.stage.style.transform = `translate(${g.tx}px, ${g.ty}px) scale(${g.s})`;
      view.s = g.s;
      if (view.line) {  // the left picture (on top) is cut at the wipe, in view coordinates
        const x = state.wipe * g.W;
        const cut = Math.min(f.width, Math.max(0, f.width - (x - g.tx) / g.s));
        view.imgs[1].style.clipPath = `inset(0 ${cut}px 0 0)`;
        view.line.style.left = x + "px";
      }
    }
    $("where").textContent = state.zoom > 1.001 ? `zoom ${state.zoom.toFixed(1)}x` : "";
  }

  function clampCentre() {
    const half = 0.5 / state.zoom;
    state.cx = Math.min(1 - half, Math.max(half, state.cx));
    state.cy = Math.min(1 - half, Math.max(half, state.cy));
  }

  function attach(view) {
    const el = view.el;
    el.addEventListener("wheel", (ev) => {
      ev.preventDefault();
      const f = frame(), g = geometry(view);
      const r = el.getBoundingClientRect();
      const mx = ev.clientX - r.left, my = ev.clientY - r.top;
      const u = (mx - g.tx) / (f.width * g.s), v = (my - g.ty) / (f.height * g.s);
      const zoom = Math.min(MAX_ZOOM, Math.max(1, state.zoom * Math.exp(-ev.deltaY * 0.002)));
      const s = g.s * zoom / state.zoom;
      state.zoom = zoom;
      state.cx = u - (mx - g.W / 2) / (f.width * s);
      state.cy = v - (my - g.H / 2) / (f.height * s);
      clampCentre();
      draw();
    }, { passive: false });
    let drag = null;
    el.addEventListener("pointerdown", (ev) => {
      drag = { x: ev.clientX, y: ev.clientY, cx: state.cx, cy: state.cy, moved: false };
      el.setPointerCapture(ev.pointerId);
      el.classList.add("dragging");
    });
    el.addEventListener("pointermove", (ev) => {
      if (!drag) return;
      const dx = ev.clientX - drag.x, dy = ev.clientY - drag.y;
      if (Math.abs(dx) + Math.abs(dy) > 3) drag.moved = true;
      const f = frame();
      state.cx = drag.cx - dx / (f.width * view.s);
      state.cy = drag.cy - dy / (f.height * view.s);
      clampCentre();
      draw();
    });
    const end = (ev) => {
      if (!drag) return;
      const click = !drag.moved;
      drag = null;
      el.classList.remove("dragging");
      if (click && !view.line && view.ids.length === 1) pick(view.ids[0], ev.shiftKey ? "right" : "left");
    };
    el.addEventListener("pointerup", end);
    el.addEventListener("pointercancel", () => { drag = null; el.classList.remove("dragging"); });
  }

  function pick(id, side) {
    state[side] = id;
    $(side).value = id;
    buildWipe();
  }

  function buildWipe() {
    views = views.filter((v) => !v.line);
    const view = makeView($("wipeview"), [state.right, state.left]);
    const line = document.createElement("div");
    line.className = "line";
    view.el.appendChild(line);
    view.line = line;
    for (const [side, cls] of [["left", "l"], ["right", "r"]]) {
      const tag = document.createElement("div");
      tag.className = "tag " + cls;
      tag.textContent = pictures.get(state[side]).title;
      view.el.appendChild(tag);
    }
    $("wipecaption").textContent =
      `Wipe: ${pictures.get(state.left).title} (left) against ${pictures.get(state.right).title} (right).`;
    document.querySelectorAll(".card").forEach((c) => {
      c.classList.toggle("left", c.dataset.picture === state.left);
      c.classList.toggle("right", c.dataset.picture === state.right);
    });
    draw();
  }

  function card(parent, id, title, lines) {
    const box = document.createElement("figure");
    box.className = "card";
    box.dataset.picture = id;
    const h = document.createElement("h3");
    h.textContent = title;
    box.appendChild(h);
    const el = document.createElement("div");
    el.className = "view";
    box.appendChild(el);
    const cap = document.createElement("figcaption");
    cap.textContent = lines;
    box.appendChild(cap);
    parent.appendChild(box);
    makeView(el, [id]);
    return box;
  }

  function metricsTable(f) {
    const t = $("metrics");
    t.textContent = "";
    const head = t.insertRow();
    for (const text of ["this frame", ...D.metrics.map((k) => label[k])]) {
      const th = document.createElement("th");
      th.textContent = text;
      head.appendChild(th);
    }
    const rows = f.images.filter((im) => im.key !== "reference");
    const best = {};  // the best value of each metric over the rows, drawn bold
    for (const k of D.metrics) {
      const values = rows.map((im) => im.metrics[k]).filter((v) => v !== null && v !== undefined);
      if (values.length) best[k] = higherIsBetter[k] ? Math.max(...values) : Math.min(...values);
    }
    for (const im of rows) {
      const row = t.insertRow();
      row.insertCell().textContent = im.title;
      for (const k of D.metrics) {
        const cell = row.insertCell();
        cell.textContent = show(k, im.metrics[k]);
        if (im.metrics[k] === best[k]) cell.className = "best";
      }
    }
  }

  function buildFrame() {
    const f = frame();
    pictures = collect(f);
    views = [];
    if (!pictures.has(state.left)) state.left = f.images[0].key;
    if (!pictures.has(state.right)) state.right = "reference";
    for (const side of ["left", "right"]) {
      const sel = $(side);
      sel.textContent = "";
      for (const [id, p] of pictures) sel.add(new Option(p.title, id));
      sel.value = state[side];
    }
    const grid = $("grid"), maps = $("maps");
    grid.textContent = "";
    maps.textContent = "";
    for (const im of f.images) {
      const m = D.metrics.filter((k) => im.metrics[k] !== null && im.metrics[k] !== undefined)
        .map((k) => `${label[k]} ${show(k, im.metrics[k])}`).join(", ");
      const box = card(grid, im.key, im.title, m || (im.key === "reference" ? "the reference" : "no metrics"));
      if (im.flip) {
        const el = document.createElement("div");
        el.className = "view";
        box.appendChild(el);
        makeView(el, [im.key + ":flip"]);
        const cap = document.createElement("figcaption");
        cap.textContent = `FLIP error map (0 black .. 1 white), mean ${im.flip.mean.toFixed(4)} here`;
        box.appendChild(cap);
      }
    }
    for (const m of f.maps) card(maps, m.key, `${D.method}: ${m.title}`, m.note);
    $("mapstitle").hidden = f.maps.length === 0;
    metricsTable(f);
    buildWipe();
  }

  function setStop(i) {
    state.stop = i;
    const ev = D.stops[i];
    $("ev").textContent = `${ev > 0 ? "+" : ""}${ev} EV`;
    for (const view of views) view.imgs.forEach((img) => {
      const src = pictures.get(img.dataset.picture).src();
      if (img.getAttribute("src") !== src) img.src = src;
    });
  }

  $("title").textContent = `Report ${D.report}: every method against the noisy input and the reference`;
  D.frames.forEach((f, i) => {
    const crop = f.full[0] > f.width || f.full[1] > f.height
      ? ` (${f.width}x${f.height} at x=${f.crop[0]}, y=${f.crop[1]} of ${f.full[0]}x${f.full[1]})` : "";
    $("frame").add(new Option(`${f.scene}, test frame ${f.frame}${crop}`, String(i)));
  });
  $("frame").addEventListener("change", (e) => { state.frame = Number(e.target.value); buildFrame(); });
  $("exposure").max = String(D.stops.length - 1);
  $("exposure").value = String(state.stop);
  $("exposure").addEventListener("input", (e) => setStop(Number(e.target.value)));
  $("left").addEventListener("change", (e) => pick(e.target.value, "left"));
  $("right").addEventListener("change", (e) => pick(e.target.value, "right"));
  $("wipe").addEventListener("input", (e) => { state.wipe = Number(e.target.value) / 1000; draw(); });
  $("reset").addEventListener("click", () => { state.zoom = 1; state.cx = state.cy = 0.5; draw(); });
  window.addEventListener("resize", draw);
  buildFrame();
  setStop(state.stop);
})();
