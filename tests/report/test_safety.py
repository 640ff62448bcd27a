"""Figure sanitising and the Content-Security-Policy of every HTML page vehval writes."""

from vehval.report.safety import CSP, CSP_META, safe_figure, safe_text

URL = "http://203.0.113.7/x"


def test_policy_allows_no_network_source():
    directives = dict(d.strip().split(" ", 1) for d in CSP.split(";"))
    assert directives["default-src"] == "'none'" and directives["connect-src"] == "'none'"
    for d in ("script-src", "img-src", "style-src", "font-src", "worker-src"):
        assert not any(s.startswith(("http", "*", "'self'")) for s in directives[d].split()), d
    assert CSP in CSP_META


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


def test_every_html_writer_carries_the_policy():
    import inspect

    from vehval.batch import index
    from vehval.cli import commands_sensitivity
    from vehval.identify import report as ident
    from vehval.report import epa, html

    for mod in (index, commands_sensitivity, ident, epa, html):
        assert "CSP_META" in inspect.getsource(mod), mod.__name__
