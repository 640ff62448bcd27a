/* vehval report: unpack the embedded plotly.js (gzip, base64) and run it. The unpacked text
   is exactly the script whose hash the page's policy lists, so it runs under that policy;
   nothing is fetched. render.js waits for window.vehvalPlotly. */
(function () {
  "use strict";
  function unpack() {
    if (window.Plotly) return Promise.resolve();
    var el = document.getElementById("plotly-gz");
    if (!el || typeof DecompressionStream === "undefined") {
      return Promise.reject(new Error("this browser cannot unpack the embedded plotly.js " +
        "(no DecompressionStream): open the report in a current Chromium, Firefox or Safari"));
    }
    var bin = atob(el.textContent.trim());
    var bytes = new Uint8Array(bin.length);
    for (var i = 0; i < bin.length; i++) bytes[i] = bin.charCodeAt(i);
    var stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream("gzip"));
    return new Response(stream).text().then(function (js) {
      var s = document.createElement("script");
      s.id = "plotly-js";
      s.textContent = js;
      document.head.appendChild(s);
      if (!window.Plotly) throw new Error("plotly.js did not start");
    });
  }
  window.vehvalPlotly = unpack();
})();
