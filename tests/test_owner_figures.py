"""One figure layer: plotly figures are built by vehval.figures (and the thin re-export
report/figures.py), nowhere else: the report's pages compute the data and hand it to the
builders; the workbench's script draws the specifications the server sends and builds no
trace itself."""

import ast
import re
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src" / "vehval"
#: The figure layer: the builders, and the report's re-export of them.
LAYER = (SRC / "figures", SRC / "report" / "figures.py")
#: Keys of a plotly layout or figure: a dict literal holding one builds a figure.
LAYOUT_KEYS = {"xaxis", "yaxis", "barmode", "yaxis2"}
STATIC = SRC / "serve" / "static"


def _inside_layer(path: Path) -> bool:
    return any(path.is_relative_to(d) for d in LAYER)


def scan() -> list[str]:
    bad = []
    for path in sorted(SRC.rglob("*.py")):
        if _inside_layer(path):
            continue
        rel = path.relative_to(SRC)
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                names = [a.name for a in node.names] if isinstance(node, ast.Import) \
                    else [node.module or ""]
                if any(n.startswith(("plotly.graph_objects", "plotly.subplots",
                                     "plotly.express")) for n in names):
                    bad.append(f"{rel}:{node.lineno}: imports {names[0]}")
            elif isinstance(node, ast.Attribute) and node.attr in ("Figure", "make_subplots") \
                    and isinstance(node.value, ast.Name) and node.value.id in ("go", "plotly"):
                bad.append(f"{rel}:{node.lineno}: {node.value.id}.{node.attr}")
            elif isinstance(node, ast.Name) and node.id == "make_subplots":
                bad.append(f"{rel}:{node.lineno}: make_subplots")
            elif isinstance(node, ast.Dict):
                keys = {k.value for k in node.keys if isinstance(k, ast.Constant)
                        and isinstance(k.value, str)}
                if keys & LAYOUT_KEYS or {"data", "layout"} <= keys:
                    bad.append(f"{rel}:{node.lineno}: a plotly layout built by hand "
                               f"({', '.join(sorted(keys & (LAYOUT_KEYS | {'layout'})))})")
    return bad


def test_no_figure_built_outside_the_layer():
    bad = scan()
    assert not bad, "build figures with vehval.figures:\n" + "\n".join(bad)


def test_the_report_pages_are_scanned():
    """The report's pages are outside the layer: a page laying out its own figure fails."""
    assert not _inside_layer(SRC / "report" / "plots.py")
    assert not _inside_layer(SRC / "report" / "energy_flow.py")
    assert _inside_layer(SRC / "report" / "figures.py")


def test_the_workbench_script_only_draws_server_specs():
    for js in sorted(STATIC.glob("*.js")):
        text = js.read_text(encoding="utf-8")
        # no trace or layout built in the page: no trace type, no axis title, no newPlot
        assert not re.search(r"type:\s*\"(scatter|bar|scattergl)\"", text), js.name
        assert "xaxis: {title" not in text and "Plotly.newPlot" not in text, js.name
        if js.name != "figures.js":
            assert "Plotly.react" not in text, f"{js.name}: draw through vehvalFigures.draw"
