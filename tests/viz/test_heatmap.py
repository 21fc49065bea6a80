"""The Fig. 2 heatmap figure: written as a PNG, labelled, drawn the right way round."""

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
from matplotlib.image import imread  # noqa: E402

from nodnav.decision.heatmap import HeatmapResult  # noqa: E402
from nodnav.viz.heatmap import COLORBAR_LABEL, XLABEL, YLABEL, heatmap_figure, plot_heatmap  # noqa: E402


def corner_result(u=10.0, converged=True):
    """A hand-made 3x3 result: 1 only where z_11(0) is largest and z_21(0) smallest."""
    z = np.array([-10.0, 0.0, 10.0])
    x11 = np.zeros((3, 3))
    x11[2, 0] = 1.0
    return HeatmapResult(u=u, z_values=z, x11=x11, converged=converged, residual=0.0, t_end=20.0)


def test_png_is_written(tmp_path):
    path = plot_heatmap(corner_result(), tmp_path / "sub" / "fig2b.png")
    assert path.exists()
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    image = imread(path)
    assert image.ndim == 3 and image.shape[0] > 100 and image.shape[1] > 100


def test_axes_colorbar_and_title_are_labelled():
    fig = heatmap_figure(corner_result(u=10.0))
    ax, cax = fig.axes
    assert ax.get_xlabel() == XLABEL and "z_{11}(0)" in XLABEL
    assert ax.get_ylabel() == YLABEL and "z_{21}(0)" in YLABEL
    assert cax.get_ylabel() == COLORBAR_LABEL and "x_{11}" in COLORBAR_LABEL
    assert "u_i = 10" in ax.get_title()
    assert "not converged" in heatmap_figure(corner_result(converged=False)).axes[0].get_title()


def test_cells_are_placed_with_z11_across_and_z21_up():
    fig = heatmap_figure(corner_result())
    mesh = fig.axes[0].collections[0]
    values = np.asarray(mesh.get_array()).reshape(3, 3)  # rows follow the vertical axis
    # x11[a=2, c=0]: z_11(0) = 10 (right), z_21(0) = -10 (bottom row).
    expected = np.zeros((3, 3))
    expected[0, 2] = 1.0
    np.testing.assert_array_equal(values, expected)
    assert mesh.get_clim() == (0.0, 1.0)
    np.testing.assert_allclose(fig.axes[0].get_xlim(), (-15.0, 15.0))
    np.testing.assert_allclose(fig.axes[0].get_ylim(), (-15.0, 15.0))
