"""`edmd tables plot`: the curves drawn are the table's matrix of restitution (physics.md §4.5, §4.7).

References: the direct two-body solver (checked in test_twobody.py) and the closed forms of
physics.md §2.2 (central contacts) and §4.5 (elastic contacts: D = 1, eps_hat = 1 exactly).
"""

import math

import numpy as np
import pytest
from matplotlib.image import imread
from typer.testing import CliRunner

from edmd.app.cli import app
from edmd.physics.contact import Hertz
from edmd.app.tableplot import COMPONENTS, as_table, plot_table
from edmd.physics.tables import DEFAULT_BOXES, TableError, default_table
from edmd.physics.twobody import solve

runner = CliRunner()
NAMES = ("Phi", "eps_hat", "D", "tau_c")  # the panel order of COMPONENTS


def _curves(fig, row: int, name: str):
    """The lines of panel ``name`` in row ``row`` (one per eccentricity)."""
    return fig.axes[row * len(COMPONENTS) + NAMES.index(name)].get_lines()


@pytest.fixture(scope="module")
def dashpot_fig():
    return plot_table("dashpot", damping=[0.0, 0.1, 0.3], b=[0.0, 0.5, 0.9], points=21)


def test_one_row_per_damping_and_one_curve_per_eccentricity(dashpot_fig):
    assert [c for c, _ in COMPONENTS] == [0, 3, 1, 2]  # Phi, eps_hat, D, tau_c of lookup_many
    fig = dashpot_fig
    assert len(fig.axes) == 3 * 4
    softness = np.linspace(*DEFAULT_BOXES["dashpot"].softness, 21)
    for row, u1 in enumerate([0.0, 0.1, 0.3]):
        for col in range(4):
            ax = fig.axes[4 * row + col]
            assert ax.get_title().endswith(f"$\\zeta_d$ = {u1:g}")
            lines = ax.get_lines()
            assert [ln.get_label() for ln in lines] == ["b = 0", "b = 0.5", "b = 0.9"]
            assert all(np.array_equal(ln.get_xdata(), softness) for ln in lines)
    assert fig.axes[-1].get_xlabel() == r"softness $\Lambda_v$"


def test_curves_equal_the_direct_solver(dashpot_fig):
    # table coordinates -> solver parameters (physics.md §4.7): Lambda = Lambda_v sqrt(1 - b^2), tan(alpha) = b / sqrt(1 - b^2)
    fig = dashpot_fig
    for row, u1 in enumerate([0.0, 0.1, 0.3]):
        for k, b in enumerate([0.0, 0.5, 0.9]):
            x = _curves(fig, row, "Phi")[k].get_xdata()
            for i in (3, 10, 20):
                ref = solve("dashpot", u1, x[i] * math.sqrt(1 - b * b), b / math.sqrt(1 - b * b))
                got = {name: _curves(fig, row, name)[k].get_ydata()[i] for name in NAMES}
                # the default tables are accurate to < 1e-6 relative (test_tables.py)
                assert got["Phi"] == pytest.approx(ref.Phi, rel=2e-6, abs=1e-12)
                assert got["eps_hat"] == pytest.approx(ref.eps_hat, rel=2e-6)
                assert got["tau_c"] == pytest.approx(ref.tau_c, rel=2e-6)
                assert 1 - got["D"] == pytest.approx(1 - ref.D, rel=2e-6, abs=1e-12)


def test_known_values_of_the_dashpot(dashpot_fig):
    fig = dashpot_fig
    for k in range(3):  # elastic row: D = 1, eps_hat = 1 exactly (physics.md §4.5)
        assert np.allclose(_curves(fig, 0, "eps_hat")[k].get_ydata(), 1.0, rtol=0, atol=1e-9)
        assert np.allclose(_curves(fig, 0, "D")[k].get_ydata(), 1.0, rtol=0, atol=1e-12)
    # head-on (b = 0): no rotation; e_n and omega_0 t_c of physics.md §2.2.1 at every softness
    for row, (tau, e_n) in enumerate([(math.pi, 1.0), (2.9560753, 0.7440794), (2.6544746, 0.4509755)]):
        assert np.allclose(_curves(fig, row, "Phi")[0].get_ydata(), 0.0, atol=1e-12)
        assert np.allclose(_curves(fig, row, "tau_c")[0].get_ydata(), tau, rtol=2e-7)
        assert np.allclose(_curves(fig, row, "eps_hat")[0].get_ydata(), e_n, rtol=2e-7)
    # hard limit Lambda_v = 0: Phi -> 0, D -> 1 at every eccentricity
    assert all(ln.get_ydata()[0] == pytest.approx(0.0, abs=1e-12) for ln in _curves(fig, 1, "Phi"))
    assert all(ln.get_ydata()[0] == pytest.approx(1.0, abs=1e-12) for ln in _curves(fig, 1, "D"))


def test_known_values_of_hertz():
    # physics.md §2.2.2: elastic tau_c(0) = 3.2180655; delta = 0.1 central: eps = 0.89285888, tau_c = 3.157256
    fig = plot_table(Hertz(young=1e8, poisson=0.3, A=1e-6), damping=[0.0, 0.1], b=[0.0, 0.8], points=11)
    assert fig.axes[0].get_title().endswith(r"$\delta_v$ = 0")
    assert np.allclose(_curves(fig, 0, "tau_c")[0].get_ydata(), 3.2180655, rtol=2e-7)
    assert np.allclose(_curves(fig, 0, "eps_hat")[1].get_ydata(), 1.0, atol=1e-9)
    assert np.allclose(_curves(fig, 1, "eps_hat")[0].get_ydata(), 0.89285888, rtol=2e-7)
    assert np.allclose(_curves(fig, 1, "tau_c")[0].get_ydata(), 3.157256, rtol=5e-7)


def test_default_rows_and_eccentricities_span_the_box():
    fig = plot_table("hertz", points=5)
    assert len(fig.axes) == 3 * 4
    assert [ax.get_title().rsplit("= ", 1)[1] for ax in fig.axes[::4]] == ["0", "0.5", "1"]
    labels = [ln.get_label() for ln in fig.axes[0].get_lines()]
    assert labels[0] == "b = 0" and labels[-1] == "b = 0.99" and len(labels) == 5


def test_sources_and_bad_input(tmp_path):
    tab = default_table("dashpot")
    path = tmp_path / "t.npz"
    tab.save(path)
    assert as_table(tab) is tab and as_table("dashpot") is tab and as_table(path).shape == tab.shape
    with pytest.raises(TableError, match="no table file"):
        as_table(tmp_path / "missing.npz")
    with pytest.raises(TableError, match=r"damping values \[0.7\] are not in the table's range \[0, 0.5\]"):
        plot_table(tab, damping=[0.1, 0.7])
    with pytest.raises(TableError, match="eccentricity b values"):
        plot_table(tab, b=[1.0])
    with pytest.raises(TableError, match="expected a restitution table"):
        as_table(3)


def test_cli_writes_the_png(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    r = runner.invoke(app, ["tables", "plot", "--model", "dashpot", "--damping", "0,0.2"])
    assert r.exit_code == 0, r.output
    image = imread(tmp_path / "restitution_dashpot.png")
    assert image.ndim == 3 and image.shape[1] > image.shape[0] > 100
    default_table("hertz").save(tmp_path / "h.npz")
    r = runner.invoke(app, ["tables", "plot", "h.npz", "-o", "h-table.png"])
    assert r.exit_code == 0, r.output
    assert imread(tmp_path / "h-table.png").shape[0] > image.shape[0]  # three rows (default) against two


@pytest.mark.parametrize(
    "args, message",
    [
        ([], "give a table file or --model"),
        (["t.npz", "--model", "hertz"], "not both"),
        (["--model", "rubber"], "unknown contact model"),
        (["--model", "dashpot", "-d", "0,x"], "--damping must be numbers"),
        (["--model", "dashpot", "-d", "0.6"], "not in the table's range"),
        (["missing.npz"], "no table file"),
    ],
)
def test_cli_errors(tmp_path, monkeypatch, args, message):
    monkeypatch.chdir(tmp_path)
    r = runner.invoke(app, ["tables", "plot", *args])
    assert r.exit_code == 2 and message in " ".join(r.output.split()), r.output
