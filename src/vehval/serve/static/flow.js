// vehval workbench, test page: the lab flow beyond QA (the report of the test, model and
// test with the vehicle named and the result kept, the tab in the URL).
"use strict";
(function () {
  if (document.body.dataset.page !== "test") return;
  const csrf = document.querySelector('meta[name="vehval-csrf"]').content;
  const dir = document.body.dataset.dir;
  const test = document.body.dataset.test;

  function el(tag, attrs, ...kids) {
    const e = document.createElement(tag);
    for (const [k, v] of Object.entries(attrs || {})) {
      if (v === null || v === undefined || v === false) continue;
      if (k === "class") e.className = v; else if (k === "text") e.textContent = v; else e.setAttribute(k, v);
    }
    for (const k of kids) if (k !== null && k !== undefined) e.append(k instanceof Node ? k : String(k));
    return e;
  }
  function fmt(x) { return (x === null || x === undefined) ? "" : (typeof x === "number" ? (Math.abs(x) >= 100 ? x.toFixed(1) : x.toFixed(3)) : String(x)); }
  function showError(msg) {
    const box = document.getElementById("error");
    box.hidden = !msg; box.textContent = msg ? "vehval: error: " + msg : "";
  }
  async function api(path, body) {
    const params = new URLSearchParams({dir});
    if (test) params.set("test", test);
    const opts = {credentials: "same-origin", headers: {}};
    if (body !== undefined) {
      opts.method = "POST"; opts.body = JSON.stringify(body);
      opts.headers["Content-Type"] = "application/json"; opts.headers["X-CSRF-Token"] = csrf;
    }
    const r = await fetch(path + "?" + params.toString(), opts);
    let data;
    try { data = await r.json(); } catch (e) { data = {error: "HTTP " + r.status}; }
    if (!r.ok) throw new Error(data.error || ("HTTP " + r.status));
    return data;
  }
  // ---------------------------------------------------------------- the tab in the URL
  function tabFromUrl() { const m = /(?:^|[#&])tab=([a-z]+)/.exec(location.hash); return m ? m[1] : null; }
  document.querySelectorAll(".tabs button").forEach(b => b.addEventListener("click", () => {
    history.replaceState(null, "", location.pathname + location.search + "#tab=" + b.dataset.tab);
    if (b.dataset.tab === "model") loadModel();
  }));
  function openTab() {
    const want = tabFromUrl();
    const b = want && document.querySelector('.tabs button[data-tab="' + want + '"]');
    if (b) b.click();
  }

  // ---------------------------------------------------------------- the report
  const reportBtn = document.getElementById("make-report");
  reportBtn.addEventListener("click", async () => {
    const note = document.getElementById("report-note");
    const link = document.getElementById("report-link");
    reportBtn.disabled = true; note.textContent = "building the report...";
    try {
      const r = await api("/api/report", {});
      link.href = "/files/" + r.report.split("/").map(encodeURIComponent).join("/");
      link.hidden = false; note.textContent = r.report;
      window.open(link.href, "_blank", "noopener");
    } catch (e) { note.textContent = ""; showError(e.message); }
    finally { reportBtn.disabled = false; }
  });

  // ---------------------------------------------------------------- model and test
  let modelLoaded = false;
  async function loadModel() {
    if (modelLoaded) return;
    modelLoaded = true;
    try { showModel(await api("/api/model")); }
    catch (e) { document.getElementById("model-vehicle").textContent = e.message; }
  }
  async function showModel(m) {
    document.getElementById("model-vehicle").textContent = "Vehicle simulated: " + m.vehicle_text
      + (m.stale ? " (the kept result is out of date: an input changed)" : "");
    const out = document.getElementById("model-out");
    out.textContent = "";
    const r = m.result;
    if (!r) return;
    out.dataset.kept = "1";
    for (const t of r.tables) {
      out.append(el("h3", {text: t.title}));
      out.append(el("table", {class: "data model-table"},
        el("thead", {}, el("tr", {}, ...t.columns.map(c => el("th", {text: c})))),
        el("tbody", {}, ...t.rows.map(row => el("tr", {}, ...(Array.isArray(row) ? row : t.columns.map(c => row[c])).map(v => el("td", {text: fmt(v)})))))));
      if (t.note) out.append(el("p", {class: "note", text: t.note}));
    }
    if (r.figure && r.traces && r.traces.length) {
      // the server's figure: one panel per quantity (its own unit), one linked time axis
      const div = el("div", {class: "plot model-plot", id: "model-plot"});
      out.append(div);
      await window.vehvalFigures.draw(div, r.figure);
      div.dataset.rows = String(r.traces.length);
    }
    for (const n of r.notes || []) out.append(el("p", {text: n}));
  }
  document.getElementById("run-model").addEventListener("click", async () => {
    const out = document.getElementById("model-out");
    out.textContent = "simulating...";
    modelLoaded = true;
    try { const r = await api("/api/model", {}); showModel({vehicle_text: r.vehicle_text, result: r}); }
    catch (e) { out.textContent = ""; showError(e.message); }
  });

  // ---------------------------------------------------------------- the car of the template
  const CONSTS = ["test_mass_kg", "road_load_a_n", "road_load_b_n_per_mps", "road_load_c_n_per_mps2"];
  let car = null;
  async function loadCar() {
    const m = await api("/api/test");
    const todo = m.todo || [];
    document.getElementById("todo").hidden = !todo.length;
    document.getElementById("todo").open = todo.length > 0 && todo.length <= 40;
    document.getElementById("todo-head").textContent = todo.length + " thing(s) to do on the template (as the command line lists them)";
    const ul = document.getElementById("todo-list"); ul.textContent = "";
    for (const t of todo) ul.append(el("li", {class: "todo", text: t}));
    car = {vehicle: m.vehicle || "", vehicle_name: m.vehicle_name || "", constants: m.constants || {}};
    document.getElementById("car-vehicle").value = car.vehicle;
    document.getElementById("car-vehicle_name").value = car.vehicle_name;
    for (const k of CONSTS) { const v = car.constants[k]; document.getElementById("car-" + k).value = (v === null || v === undefined) ? "" : String(v); }
  }
  document.getElementById("car-save").addEventListener("click", async () => {
    const note = document.getElementById("car-note");
    const body = {constants: {}};
    for (const k of ["vehicle", "vehicle_name"]) {
      const v = document.getElementById("car-" + k).value.trim();
      if (v !== car[k]) body[k] = v;
    }
    for (const k of CONSTS) {
      const text = document.getElementById("car-" + k).value.trim();
      const old = car.constants[k];
      if (text === "") { if (old !== null && old !== undefined) body.constants[k] = null; continue; }
      const v = Number(text);
      if (!Number.isFinite(v)) { showError(k + ": '" + text + "' is not a number"); return; }
      if (v !== old) body.constants[k] = v;
    }
    note.textContent = "saving...";
    try {
      await api("/api/template", body);
      note.textContent = "saved"; showError("");
      location.reload();
    } catch (e) { note.textContent = ""; showError(e.message); }
  });

  window.addEventListener("DOMContentLoaded", () => { setTimeout(openTab, 0); loadCar().catch(e => showError(e.message)); });
})();
