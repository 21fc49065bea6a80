"""The gallery of a family's draws is written as a PNG (Agg, no display)."""

import matplotlib

matplotlib.use("Agg")

from matplotlib.image import imread  # noqa: E402

from nodnav.cli import main  # noqa: E402


def test_show_family_writes_a_gallery(tmp_path, capsys):
    out = tmp_path / "gallery.png"
    assert main(["show", "paper-like", "--seed", "4", "--count", "2", "--out", str(out)]) == 0
    image = imread(out)
    assert image.shape[0] > 200 and image.shape[1] > 400 and image[..., :3].std() > 0.05  # drawn, not blank
    assert str(out) in capsys.readouterr().out
    assert main(["show", "paper-like", "--count", "0", "--out", str(out)]) == 2
