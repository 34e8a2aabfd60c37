import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from sloshrom.pipeline import html as report  # noqa: E402


def test_report_is_self_contained(tmp_path):
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    png = tmp_path / "f.png"
    fig.savefig(png)
    plt.close(fig)
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
