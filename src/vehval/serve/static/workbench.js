// vehval workbench: one script for every page (no inline script: the page policy forbids it).
"use strict";
(function () {
  const csrf = document.querySelector('meta[name="vehval-csrf"]').content;
  const page = document.body.dataset.page;
  const N = 4000;  // points per trace (min/max decimated beyond, exact when zoomed in)
  function el(tag, attrs, ...kids) {
    const e = document.createElement(tag);
    for (const [k, v] of Object.entries(attrs || {})) {
      if (v === null || v === undefined || v === false) continue;
      if (k === "class") e.className = v; else if (k === "text") e.textContent = v;
      else if (k.startsWith("data-")) e.setAttribute(k, v); else e[k] = v;
    }
    for (const k of kids) if (k !== null && k !== undefined) e.append(k instanceof Node ? k : String(k));
    return e;
  }
  function qs(params) { return new URLSearchParams(Object.entries(params).filter(([, v]) => v !== null && v !== undefined)).toString(); }
  function showError(msg) {
    const box = document.getElementById("error");
    if (!box) return;
    box.hidden = !msg; box.textContent = msg ? "vehval: error: " + msg : "";
  }
  async function api(path, params, body) {
    const opts = {credentials: "same-origin", headers: {}};
    if (body !== undefined) {
      opts.method = "POST"; opts.body = JSON.stringify(body);
      opts.headers["Content-Type"] = "application/json"; opts.headers["X-CSRF-Token"] = csrf;
    }
    const one = document.body.dataset.test;   // one test of a folder of many
    if (one && params && params.dir !== undefined && params.test === undefined) params = Object.assign({test: one}, params);
    const r = await fetch(path + "?" + qs(params || {}), opts);
    let data;
    try { data = await r.json(); } catch (e) { data = {error: "HTTP " + r.status}; }
    if (!r.ok) { const e = new Error(data.error || ("HTTP " + r.status)); e.status = r.status; throw e; }
    return data;
  }
  function fmt(x, d) { return (x === null || x === undefined) ? "" : (typeof x === "number" ? x.toFixed(d === undefined ? 3 : d) : String(x)); }
  // ------------------------------------------------------------------ test page
  function testPage() {
    const dir = document.body.dataset.dir;
    let model = null;
    document.querySelectorAll(".tabs button").forEach(b => b.addEventListener("click", () => {
      document.querySelectorAll(".tabs button").forEach(x => x.classList.toggle("on", x === b));
      for (const t of ["template", "triage", "model"]) document.getElementById("tab-" + t).hidden = (t !== b.dataset.tab);
    }));

    function withheldText(w) {
      // the gate's entry: {signals, reason, fix, ...}; a plain reason otherwise
      if (!w) return "no fuel economy";
      if (typeof w === "string") return w;
      const parts = [w.reason || "QA error on " + (w.signals || []).join(", ")];
      if (w.fix) parts.push("fix: " + w.fix);
      return parts.join("; ");
    }

    function headline(h) {
      // the results layer's headline (vehval.results.headline): figure with U, rule, caveats
      const box = document.getElementById("headline");
      box.textContent = "";
      if (!h) { box.append("No result yet: save the template or rerun QA."); return; }
      const title = el("b", {text: (h.shown || h.name || "test") + ": "});
      if (h.kind === "headline" || h.kind === "forced") {
        box.append(title, el("span", {id: "headline-figure", text: h.figure}));
        // the numbers behind the sentence: fuel economy, or a BEV's SAE J1634 MPGe
        if (h.fuel_economy_mpg != null) box.append(el("span", {id: "headline-mpg", hidden: true, text: h.fuel_economy_mpg.toFixed(2)}));
        if (h.electric) box.append(el("span", {id: "headline-mpge", hidden: true, text: h.electric.mpge.toFixed(2)}));
      } else {
        box.append(title, el("span", {class: "withheld", id: "headline-withheld",
                                      text: "withheld: " + withheldText(h.withheld)}));
      }
      const lines = el("ul", {id: "headline-lines", class: "headline-lines"});
      for (const line of (h.banner && h.banner.lines) || []) {
        lines.append(el("li", {class: line.startsWith("Caveat") ? "caveat" : "", text: line}));
      }
      if (h.j1711) box.append(" ", el("span", {id: "headline-j1711", class: "j1711", text: "SAE J1711: " + h.j1711.replace(/_/g, " ")}));
      if (lines.childNodes.length) box.append(lines);
    }

    function render(m) {
      model = m;
      showError(m.error);
      headline(m.headline);
      const fuel = document.getElementById("fuel");
      fuel.textContent = "";
      fuel.append(el("option", {value: "", text: "(not declared)"}));
      for (const f of m.fuels || []) fuel.append(el("option", {value: f, text: f, selected: m.fuel === f}));
      if (m.fuel && !(m.fuels || []).includes(m.fuel)) fuel.append(el("option", {value: m.fuel, text: m.fuel, selected: true}));
      document.getElementById("saved-note").textContent = m.saved ? "" : "(proposed by template init: not saved yet)";
      const lo = document.getElementById("left-out");
      lo.textContent = ""; lo.hidden = !(m.left_out && m.left_out.length);
      if (!lo.hidden) lo.append(el("b", {text: "Left out of this folder (never read): "}));
      for (const x of m.left_out || []) lo.append(el("div", {class: "left-out", text: x.name + ": " + x.why}));
      const files = document.getElementById("files");
      files.textContent = "";
      for (const f of m.files) {
        files.append(el("h2", {text: (f.file || "(no file matches " + (f.match || "") + ")") + " "},
                        "source ", el("input", {class: "src", value: f.source, "data-file": f.index, size: 8})));
        for (const n of f.notes || []) files.append(el("div", {class: "note file-note", text: "read with a repair: " + n}));
        const tb = el("tbody");
        for (const c of f.channels) {
          const hints = el("div", {class: "hints"});
          for (const h of c.hints) hints.append(el("div", {class: "hint", text: (h.fix ? h.fix + " — " : "") + h.message}));
          const row = el("tr", {"data-file": f.index, "data-raw": c.raw, class: c.delete ? "deleted" : ""},
            el("td", {}, el("code", {text: c.raw}), c.header_unit ? " [" + c.header_unit + "]" : ""),
            el("td", {}, el("input", {class: "ch-name", value: c.name || "", "data-orig": c.name || ""})),
            el("td", {}, el("input", {class: "ch-unit", value: c.unit || "", "data-orig": c.unit || "", placeholder: c.header_unit || ""})),
            el("td", {text: c.si_unit || ""}),
            el("td", {class: "conf-" + c.confidence, text: c.confidence}),
            el("td", {}, el("input", {type: "checkbox", class: "ch-delete", checked: c.delete, "data-orig": c.delete ? "1" : "0"}),
               " ", el("input", {class: "ch-reason", value: c.delete ? (c.reason || "") : "", placeholder: "reason", size: 12})),
            el("td", {}, hints),
            el("td", {}, c.in_file ? el("button", {class: "plot-ch", text: "plot"}) : ""));
          tb.append(row);
        }
        files.append(el("table", {class: "data channels"},
          el("thead", {}, el("tr", {}, ...["raw channel [file unit]", "standard name", "unit", "SI", "confidence", "delete", "QA unit hints", ""].map(t => el("th", {text: t})))), tb));
      }
      files.querySelectorAll("button.plot-ch").forEach(b => b.addEventListener("click", () => {
        const tr = b.closest("tr");
        const f = model.files[Number(tr.dataset.file)];
        plotChannel(f.file, tr.dataset.raw).catch(e => showError(e.message));
        files.querySelectorAll("tr.sel").forEach(r => r.classList.remove("sel")); tr.classList.add("sel");
      }));
      renderTriage(m);
    }

    async function plotChannel(file, raw) {
      const div = document.getElementById("chplot");
      await window.vehvalFigures.zoomable(div, async (t0, t1) => (await api("/api/channel", {dir, file, raw, t0, t1, n: N})).figure);
      div.dataset.channel = raw;
    }

    function renderTriage(m) {
      const s = m.summary;
      const n = (k, word) => `${k} ${word}${k === 1 ? "" : "s"}`;
      const later = (m.findings || []).filter(f => f.stage === "results").length;
      document.getElementById("summary").textContent = s ? `${n(s.total, "finding")} (${n(s.by_severity.error, "error")}, ${n(s.by_severity.warning, "warning")}, ${s.by_severity.info} info); kept ${s.kept}, dropped ${s.dropped}, computed ${s.computed}` + (later ? `; and ${n(later, "finding")} of the results stage` : "") : "QA has not run.";
      const tb = document.querySelector("#findings tbody");
      const fp = document.getElementById("findplot");
      if (fp && fp.closest("#findings")) { if (window.Plotly) Plotly.purge(fp); fp.textContent = ""; document.getElementById("findplot-home").append(fp); }
      tb.textContent = "";
      (m.findings || []).forEach((f, i) => {
        const tr = el("tr", {class: "finding", "data-index": i, "data-stage": f.stage || "qa"},
          el("td", {class: "sev-" + f.severity, text: f.severity}), el("td", {text: f.stage || "qa"}), el("td", {text: f.kind}),
          el("td", {text: f.signal}), el("td", {text: f.start_s === null ? "" : fmt(f.start_s, 1) + " – " + fmt(f.end_s, 1)}),
          el("td", {text: f.message}), el("td", {text: f.fix || ""}));
        tr.addEventListener("click", () => { openFinding(f, i, tr).catch(e => showError(e.message)); tb.querySelectorAll("tr.sel").forEach(r => r.classList.remove("sel")); tr.classList.add("sel"); });
        tb.append(tr);
      });
      const sel = m.selection || {kept: {}, dropped: {}};
      const user = m.user_selection || {keep: [], drop: {}};
      const st = document.querySelector("#selection tbody");
      st.textContent = "";
      const names = [...Object.keys(sel.kept || {}), ...Object.keys(sel.dropped || {})].sort();
      for (const n of names) {
        const kept = n in (sel.kept || {});
        const reason = kept ? sel.kept[n] : sel.dropped[n];
        const userSet = user.keep.includes(n) || n in user.drop;
        const rin = el("input", {class: "drop-reason", placeholder: "reason to drop", size: 24});
        const actions = el("td", {}, rin, " ",
          el("button", {class: "drop-btn", text: "drop"}), " ", el("button", {class: "keep-btn", text: "keep"}),
          userSet ? el("button", {class: "clear-btn", text: "clear"}) : null);
        const tr = el("tr", {"data-signal": n}, el("td", {}, el("code", {text: n})),
                      el("td", {text: kept ? "kept" : "dropped"}), el("td", {text: reason}), actions);
        actions.querySelector(".drop-btn").addEventListener("click", () => decide(n, "drop", rin.value));
        actions.querySelector(".keep-btn").addEventListener("click", () => decide(n, "keep", ""));
        const cb = actions.querySelector(".clear-btn");
        if (cb) cb.addEventListener("click", () => decide(n, "clear", ""));
        st.append(tr);
      }
    }

    // the finding's figure (built by the server for its kind) in a row under the finding
    async function openFinding(f, i, tr) {
      const div = document.getElementById("findplot");
      let row = document.getElementById("findplot-row");
      if (!row) {
        row = el("tr", {id: "findplot-row"}, el("td", {colSpan: 7}));
      }
      row.firstChild.append(div);
      tr.after(row);
      div.dataset.finding = "";
      let r;
      try { r = await api("/api/finding", {dir, i}); } catch (e) {
        if (e.status !== 409) throw e;
        await runQA();
        r = await api("/api/finding", {dir, i});
      }
      await window.vehvalFigures.draw(div, r.figure);
      div.dataset.finding = f.kind + ":" + f.signal;
    }

    async function busy(p) {
      const b = document.getElementById("busy");
      b.hidden = false; document.body.dataset.busy = "1";
      try { render(await p); } catch (e) { showError(e.message); } finally { b.hidden = true; document.body.dataset.busy = "0"; document.body.dataset.runs = String(Number(document.body.dataset.runs || 0) + 1); }
    }
    function decide(signal, action, reason) { busy(api("/api/selection", {dir}, {signal, action, reason})); }
    // QA runs only on a POST: a signal asked before this server ran QA answers 409, and the
    // page runs it (one run shared by every plot waiting), then asks again
    let running = null;
    function runQA() {
      if (!running) running = busy(api("/api/run", {dir}, {})).finally(() => { running = null; });
      return running;
    }
    async function signal(params) {
      try { return await api("/api/signal", params); } catch (e) {
        if (e.status !== 409) throw e;
        await runQA();
        return await api("/api/signal", params);
      }
    }

    document.getElementById("save").addEventListener("click", () => {
      const edits = {channels: [], sources: {}, fuel: document.getElementById("fuel").value};
      document.querySelectorAll("#files tr[data-raw]").forEach(tr => {
        const name = tr.querySelector(".ch-name"), unit = tr.querySelector(".ch-unit"), del = tr.querySelector(".ch-delete");
        const ch = {file: Number(tr.dataset.file), raw: tr.dataset.raw};
        let changed = false;
        if (name.value !== name.dataset.orig) { ch.name = name.value; changed = true; }
        if (unit.value !== unit.dataset.orig) { ch.unit = unit.value; changed = true; }
        if ((del.checked ? "1" : "0") !== del.dataset.orig) {
          ch.delete = del.checked; changed = true;
          if (del.checked) ch.reason = tr.querySelector(".ch-reason").value || "deleted in the workbench";
        }
        if (changed) edits.channels.push(ch);
      });
      document.querySelectorAll("#files input.src").forEach(i => { if (i.value !== model.files[Number(i.dataset.file)].source) edits.sources[i.dataset.file] = i.value; });
      if ((model.fuel || "") === edits.fuel) delete edits.fuel;
      busy(api("/api/template", {dir}, edits));
    });
    document.getElementById("rerun").addEventListener("click", () => runQA());
    // model and test, the report and the tab in the URL: flow.js
    busy(api("/api/test", {dir}).then(m => (m.saved && !m.summary && !m.error) ? api("/api/run", {dir}, {}) : m));
  }

  // ------------------------------------------------------------------ catalog page
  function catalogPage() {
    const db = document.body.dataset.db;
    let rows = [];
    async function load() {
      const params = {db};
      document.querySelectorAll("select[data-filter]").forEach(s => { if (s.value) params[s.dataset.filter] = s.value; });
      try {
        const r = await api("/api/catalog", params);
        rows = r.rows;
        document.querySelectorAll("select[data-filter]").forEach(s => {
          const cur = s.value; s.textContent = "";
          s.append(el("option", {value: "", text: "(all)"}));
          for (const v of r.options[s.dataset.filter] || []) s.append(el("option", {value: v, text: v, selected: v === cur}));
        });
        const head = document.querySelector("#catalog thead"), body = document.querySelector("#catalog tbody");
        head.textContent = ""; body.textContent = "";
        // the server's view: display units and names, the headline with U
        const cols = r.view.columns;
        head.append(el("tr", {}, el("th", {text: "overlay"}), ...cols.map(c => el("th", {"data-col": c.key, text: c.label})), el("th", {text: "report"})));
        rows.forEach((row, i) => {
          const cells = r.view.rows[i];
          body.append(el("tr", {"data-test": row.test_id},
            el("td", {}, el("input", {type: "checkbox", class: "pick", value: row.test_id})),
            ...cols.map(c => el("td", {"data-col": c.key, class: "col-" + c.key, title: c.key === "error" ? cells[c.key] : null, text: cells[c.key]})),
            el("td", {}, row.report ? el("a", {href: "/files/" + row.report.split("/").map(encodeURIComponent).join("/"), target: "_blank", text: "report"}) : "")));
        });
        document.body.dataset.rows = String(rows.length);
        showError(null);
      } catch (e) { showError(e.message); }
    }
    document.querySelectorAll("select[data-filter]").forEach(s => s.addEventListener("change", load));
    document.getElementById("overlay").addEventListener("click", async () => {
      const picks = [...document.querySelectorAll("input.pick:checked")].map(i => i.value);
      const q = document.getElementById("quantity").value;
      try {
        const axis = document.getElementById("axis").value;
        const r = await api("/api/catalog/overlay", {db, tests: picks.join(","), q, n: N, axis});
        const div = document.getElementById("overlayplot");
        await window.vehvalFigures.draw(div, r.figure);
        const note = document.getElementById("overlay-missing");
        note.hidden = !(r.missing && r.missing.length);
        note.textContent = (r.missing || []).join("; ");
      } catch (e) { showError(e.message); }
    });
    load();
  }

  window.addEventListener("DOMContentLoaded", () => {
    if (page === "test") testPage();
    else if (page === "catalog") catalogPage();
  });
})();
