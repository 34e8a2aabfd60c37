from matplotlib.figure import Figure

from sloshrom.pipeline import html as report
from sloshrom.plotting import savefig


def test_report_is_self_contained(tmp_path):
    fig = Figure()
    fig.subplots().plot([0, 1], [0, 1])
    png = savefig(fig, tmp_path / "f.png")
    out = report.write(
        tmp_path / "r.html",
        "T",
        "<p>intro</p>",
        [report.Section("S", "<p>x</p>", [report.Figure(png, "cap")],
                        [report.Table(["a", "b"], [[1, 0.123456]])])],
    )
    text = out.read_text()
    assert "data:image/png;base64," in text and "0.1235" in text
    # nothing that a browser would fetch from the network
    assert "http://" not in text and "https://" not in text and "src='/" not in text

