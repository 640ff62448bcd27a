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

  window.vehvalFigures = {draw, axisUnits};
})();
