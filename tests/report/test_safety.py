"""Figure sanitising and the Content-Security-Policy of every HTML page vehval writes."""

from vehval.report.safety import CSP, content_security_policy, safe_figure, safe_text, script_hash

URL = "http://203.0.113.7/x"


def _directives(policy: str) -> dict[str, str]:
    return dict(d.strip().split(" ", 1) for d in policy.split(";"))


def test_policy_allows_no_network_source_and_no_inline_script():
    h = script_hash("console.log(1)")
    for policy in (CSP, content_security_policy([h]), content_security_policy([h], local_scripts=True)):
        directives = _directives(policy)
        assert directives["default-src"] == "'none'" and directives["connect-src"] == "'none'"
        for d in ("script-src", "img-src", "style-src", "font-src", "worker-src"):
            assert not any(s.startswith(("http", "*", "'self'")) for s in directives[d].split()), d
        assert "unsafe" not in directives["script-src"]
    assert _directives(CSP)["script-src"] == "'none'"
    assert _directives(content_security_policy([h]))["script-src"] == h
    assert _directives(content_security_policy([h], local_scripts=True))["script-src"] == f"{h} file:"
    # the hash of a known text (CSP Level 3: base64 of the SHA-256 of the UTF-8 bytes)
    assert script_hash("") == "'sha256-47DEQpj8HBSa+/TImW+5JCeuQeRkm5NMpJWZG3hSuFU='"


def test_text_loses_links_images_and_css_urls():
    s = safe_text(f"<a href='{URL}'>a</a> <img src='{URL}'> <span style='fill:url({URL})'>b</span>")
    assert "<a" not in s and "<img" not in s and "url(" not in s and "http:" not in s
    assert "a" in s and "b" in s


def test_figure_keeps_plots_and_drops_what_loads():
    fig = {"data": [{"type": "scatter", "x": [1], "y": [2], "name": f"<a href='{URL}'>n</a>"},
                    {"type": "scattergeo"}, {"type": "choroplethmapbox"}, {"type": "image"},
                    {"y": [1]}],
           "layout": {"images": [{"source": URL}, {"source": "data:image/png;base64,AAAA"}],
                      "geo": {}, "mapbox2": {}, "title": {"text": "ok"}},
           "frames": [{"data": [{"type": "scattergeo"}]}]}
    out = safe_figure(fig)
    assert [t.get("type", "scatter") for t in out["data"]] == ["scatter", "scatter"]
    assert out["data"][0]["name"] == "n"
    assert out["layout"]["images"] == [{"source": "data:image/png;base64,AAAA"}]
    assert "geo" not in out["layout"] and "mapbox2" not in out["layout"] and "frames" not in out
    assert out["layout"]["title"] == {"text": "ok"}


def test_every_html_page_is_rendered_by_the_template_family():
    """No module builds HTML by hand: every page goes through report.page.render_page."""
    import re
    from pathlib import Path

    import vehval

    src = Path(vehval.__file__).parent
    markup = re.compile(r"""["'](<!DOCTYPE|<html|<t[dhr][ >]|<div|<table|<h[1-6]>|<p>|<li>|<script)""", re.I)
    offenders = [f"{p.relative_to(src)}:{i}" for p in sorted(src.rglob("*.py"))
                 for i, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
                 if markup.search(line)]
    assert offenders == []


def test_webgl_traces_drawn_as_svg_or_dropped():
    """plotly.js's regl traces compile code with Function(): the policy has no 'unsafe-eval'."""
    fig = {"data": [{"type": "scattergl", "x": [1], "y": [2]}, {"type": "scatterpolargl", "r": [1]},
                    {"type": "splom", "dimensions": []}, {"type": "parcoords", "dimensions": []}]}
    out = safe_figure(fig)
    assert [t["type"] for t in out["data"]] == ["scatter", "scatterpolar"]
    assert fig["data"][0]["type"] == "scattergl"                      # input not modified
