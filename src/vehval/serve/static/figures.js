// vehval workbench: draws the figure specifications the server sends (vehval.report's figure
// layer builds every figure: units, axes, linked time, flagged spans). No trace is built here.
"use strict";
(function () {
  const ready = () => new Promise(resolve => {
    if (window.Plotly) { resolve(); return; }
    const poll = setInterval(() => { if (window.Plotly) { clearInterval(poll); resolve(); } }, 50);
  });
  const config = {responsive: true, displaylogo: false};

  // draw a {data, layout} spec into div; records what was drawn for the page's tests
  async function draw(div, spec) {
    await ready();
    const layout = Object.assign({}, spec.layout);
    await Plotly.react(div, spec.data, layout, config);
    const units = (layout.meta && layout.meta.units) || [];
    div.dataset.units = JSON.stringify(units);
    div.dataset.traces = String((spec.data || []).length);
    div.dataset.points = String((layout.meta && layout.meta.points) || 0);
  }

  // the y axes of a drawn figure and the units of the traces on each (one unit per axis)
  function axisUnits(div) {
    const out = {};
    const lay = div.layout || {};
    for (const t of div.data || []) {
      const axis = "yaxis" + String(t.yaxis || "y").slice(1);
      let unit = t.meta && t.meta.unit;
      if (unit === undefined) {
        const title = ((lay[axis] || {}).title || {}).text || "";
        const m = title.match(/\[([^\]]*)\]$/);
        unit = m ? m[1] : "";
      }
      (out[axis] = out[axis] || []).includes(unit) || out[axis].push(unit);
    }
    return out;
  }

  // a figure whose spec the server rebuilds exactly for the window zoomed into
  // (fetchSpec: (t0, t1) -> promise of a spec; null, null: the whole trace)
  async function zoomable(div, fetchSpec) {
    const show = async (t0, t1) => {
      const spec = await fetchSpec(t0, t1);
      if (t0 !== null) spec.layout = Object.assign({}, spec.layout, {xaxis: Object.assign({}, spec.layout.xaxis, {range: [t0, t1]})});
      await draw(div, spec);
      div.dataset.exact = spec.layout.meta && spec.layout.meta.exact ? "1" : "0";
    };
    div._show = show;
    div._drawing = true;
    try { await show(null, null); } finally { div._drawing = false; }
    if (div.dataset.zoomBound) return;
    div.dataset.zoomBound = "1";
    div.on("plotly_relayout", ev => {
      const r = ev["xaxis.range"] || (ev["xaxis.range[0]"] !== undefined ? [ev["xaxis.range[0]"], ev["xaxis.range[1]"]] : null);
      if (div._drawing) return;
      if (!ev["xaxis.autorange"] && !r) return;
      div._drawing = true;
      const p = ev["xaxis.autorange"] ? div._show(null, null) : div._show(r[0], r[1]);
      p.catch(e => console.warn(e.message)).finally(() => { div._drawing = false; });
    });
  }

  window.vehvalFigures = {draw, axisUnits, zoomable};
})();
