"""The public figure functions of mlayer.plotting.plot (every figure the command line draws): each
returns a matplotlib Figure with the axes it documents, writes it to ``path`` when given, and
refuses inputs it cannot draw with one line."""
import numpy as np
import pytest

from conftest import need

need("plot")

import mlayer  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from mlayer.plotting import plot  # noqa: E402


@pytest.fixture(scope="module")
def clip():
    return mlayer.data.load_sample()[:240]


@pytest.fixture(scope="module")
def model(clip):
    return mlayer.PrimitiveModel.fit(clip, k="auto", ks=range(2, 5), som=(5, 5),
                                     lattice=(3, 3), epochs=3, progress=False)


def _labels(fig):
    return [(a.get_xlabel(), a.get_ylabel()) for a in fig.axes]


def test_every_figure_the_cli_draws_is_public():
    for name in ("plot_layers", "plot_contacts", "plot_resample_variance", "plot_timewarp",
                 "plot_stream", "plot_som", "plot_elbow", "plot_transitions"):
        assert name in plot.__all__ and callable(getattr(plot, name))


def test_plot_contacts(clip, tmp_path):
    names, c = mlayer.detect_contacts(clip)
    fig = plot.plot_contacts(names, c, clip.fps, tmp_path / "c.png")
    assert isinstance(fig, Figure) and len(fig.axes) == 1
    ax = fig.axes[0]
    assert [t.get_text() for t in ax.get_yticklabels()] == list(names)
    assert ax.get_xlim() == pytest.approx((0, clip.n_frames / clip.fps))
    # one bar per contact interval
    intervals = mlayer.guards.contacts.contact_intervals
    n_intervals = sum(len(intervals(c[:, i])) for i in range(len(names)))
    assert sum(len(coll.get_paths()) for coll in ax.collections) == n_intervals
    assert (tmp_path / "c.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(mlayer.InvalidArgumentError, match="contacts must be"):
        plot.plot_contacts(names[:1], c, clip.fps)


def test_plot_resample_variance(clip):
    out, var = mlayer.resample(clip, fps=60, return_var=True)
    obs = np.arange(clip.n_frames) * (out.n_frames - 1) / (clip.n_frames - 1)
    fig = plot.plot_resample_variance(var, out.fps, obs, title="v")
    assert isinstance(fig, Figure) and len(fig.axes) == 1
    ax = fig.axes[0]
    assert ax.get_title() == "v"
    assert _labels(fig) == [("output time (s)", "variance (x sigma^2)")]
    np.testing.assert_allclose(ax.lines[0].get_ydata(), var)


def test_plot_timewarp(clip):
    t = mlayer.timewarp_map(clip, strength=1.5)
    warped = mlayer.timewarp(clip, time_map=t)
    fig = plot.plot_timewarp(clip, warped, t)
    assert isinstance(fig, Figure) and len(fig.axes) == 3
    assert [y for _, y in _labels(fig)] == ["output time (s)", "motion speed\n(rad / frame)",
                                            "root Y"]
    # the default speed is timewarp_speed's
    np.testing.assert_allclose(fig.axes[1].lines[0].get_ydata(), mlayer.timewarp_speed(clip))


def test_plot_stream(clip):
    m = clip[:40]
    y = mlayer.pipeline.stream.motion_channels(m)
    fig = plot.plot_stream(m, y, y, y + 0.01, y - 0.02, joint=1, component=2, lag=3, lam=1.0,
                           sigma=1.0, cutoff=2.0, beta=0.0)
    assert isinstance(fig, Figure) and len(fig.axes) == 2
    assert fig.axes[0].get_ylabel() == f"{m.joint_names[1]} q.y"
    diff = fig.axes[1].lines[0].get_ydata()
    np.testing.assert_allclose(diff, 0.01)


def test_plot_som(model):
    fig = plot.plot_som(model, title="som")
    assert isinstance(fig, Figure) and len(fig.axes) == 1
    ax = fig.axes[0]
    assert ax.get_title() == "som"
    assert _labels(fig) == [("lattice column", "lattice row")]
    assert len(ax.images) == 1  # the U-matrix
    assert ax.images[0].get_array().shape == model.som_codebook.shape[:2]
    with pytest.raises(mlayer.InvalidArgumentError, match="clip must be"):
        plot.plot_som(model, clip=5)


def test_plot_elbow(model):
    fig = plot.plot_elbow(model)
    assert isinstance(fig, Figure)
    assert [y for _, y in _labels(fig)] == ["k-means inertia", "silhouette", "GMM BIC"]
    np.testing.assert_allclose(fig.axes[0].lines[0].get_xdata(), model.elbow_ks)


def test_plot_transitions(model):
    fig = plot.plot_transitions(model)
    assert isinstance(fig, Figure) and len(fig.axes) == 2  # the matrix and its colour bar
    np.testing.assert_allclose(fig.axes[0].images[0].get_array(), model.markov.P)
