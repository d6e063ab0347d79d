"""`plot SWEEP`: a figure of sweep.csv against a swept value, one curve per combination of the
other swept values, runs that did not complete left out (a table written by hand, so that the
expected curves are known without running anything)."""
import pytest

from orchestrate.cli import main
from orchestrate.freefem import InputError
from orchestrate.plot import plot_sweep, read_sweep, series
from orchestrate.sweep import write_table

pytestmark = pytest.mark.unit

LOADS = ("-10*min(t, 1)", "atan2(y, x)*t")


@pytest.fixture
def table(tmp_path):
    rows = [{"time.N": 40, "body1.boundary.0.fy": LOADS[0], "folder": "a", "status": "completed", "normV": 2.0},
            {"time.N": 20, "body1.boundary.0.fy": LOADS[0], "folder": "b", "status": "skipped (complete)", "normV": 1.0},
            {"time.N": 20, "body1.boundary.0.fy": LOADS[1], "folder": "c", "status": "failed", "error": "SolverError"},
            {"time.N": 40, "body1.boundary.0.fy": LOADS[1], "folder": "d", "status": "completed", "normV": 3.0}]
    write_table(tmp_path / "sweep.csv", rows, ["time.N", "body1.boundary.0.fy"])
    return tmp_path


def test_curves_per_other_value_in_order_and_failures_left_out(table):
    keys, rows = read_sweep(table)
    assert keys == ["time.N", "body1.boundary.0.fy"]
    curves, ticks, left_out = series(keys, rows, "time.N", "normV")
    assert curves == {f"body1.boundary.0.fy = {LOADS[0]}": [(20.0, 1.0), (40.0, 2.0)],
                      f"body1.boundary.0.fy = {LOADS[1]}": [(40.0, 3.0)]}
    assert ticks is None and left_out == ["c"]


def test_expressions_along_the_axis_in_the_sweeps_order(table):
    curves, ticks, _ = series(*read_sweep(table), "body1.boundary.0.fy", "normV")
    assert ticks == {0: LOADS[0], 1: LOADS[1]}
    assert curves == {"time.N = 40": [(0, 2.0), (1, 3.0)], "time.N = 20": [(0, 1.0)]}


def test_the_image_and_the_errors(table, capsys):
    target = plot_sweep(table, "normV", log="y")
    assert target == table / "normV-vs-time.N.png" and target.stat().st_size > 5000
    assert main(["plot", str(table), "--y", "normV", "--x", "body1.boundary.0.fy", "--out", str(table / "x.svg")]) == 0
    assert (table / "x.svg").read_text().startswith("<?xml")
    with pytest.raises(InputError, match=r"--x glue.gammaNu: not a swept key .*swept: time.N, body1.boundary.0.fy"):
        series(*read_sweep(table), "glue.gammaNu", "normV")
    assert main(["plot", str(table.parent / "nowhere"), "--y", "normV"]) == 2
    assert "is neither a sweep's folder (no sweep.csv) nor a run folder" in capsys.readouterr().err
    with pytest.raises(InputError, match=r"--out .*x.txt: give a file name ending in .png, .pdf, .svg"):
        plot_sweep(table, "normV", target=table / "x.txt")
    with pytest.raises(InputError, match="no run of the sweep completed with a value of betaMin"):
        plot_sweep(table, "betaMin")  # no completed row has it
    (table / "sweep.csv").write_text("")
    with pytest.raises(InputError, match="holds no sweep's rows"):
        read_sweep(table)


def test_a_label_that_is_bad_tex_is_drawn_as_written(tmp_path):
    """A swept value (or key) with dollar signs is an expression, not mathtext: `$x^$` is drawn as
    written, not a 35-frame traceback of matplotlib's TeX parser."""
    import matplotlib

    rows = [{"a$x^$": value, "b": other, "folder": f"r{i}", "status": "completed", "normV": float(i)}
            for i, (value, other) in enumerate([("$x^$", r"$\frac{$"), ("y", r"$\frac{$"), ("$x^$", "1$")])]
    write_table(tmp_path / "sweep.csv", rows, ["a$x^$", "b"])
    with matplotlib.rc_context({"svg.fonttype": "none"}):  # text kept as text, to be read back
        for x in ("a$x^$", "b"):
            assert main(["plot", str(tmp_path), "--y", "normV", "--x", x, "--out", str(tmp_path / f"{x}.svg")]) == 0
    drawn = (tmp_path / "a$x^$.svg").read_text()
    assert "$x^$" in drawn and r"b = $\frac{$" in drawn and ">a$x^$<" in drawn
    assert "b = 1$" in drawn and r"a$x^$ = $x^$" in (tmp_path / "b.svg").read_text()


def test_an_existing_image_is_replaced_only_with_force_and_only_one_drawn_here(table, capsys):
    """A second plot to the same file asks for --force; --force replaces an image this program
    drew (its Creator says so), never another file, and nothing is written through a link."""
    target = plot_sweep(table, "normV")
    assert main(["plot", str(table), "--y", "normV"]) == 2
    assert f"--out {target} exists: pass --force to replace it" in capsys.readouterr().err
    assert plot_sweep(table, "normV", force=True) == target
    photo, victim = table / "photo.png", table / "victim.png"
    photo.write_bytes(b"\x89PNG the user's")
    assert main(["plot", str(table), "--y", "normV", "--out", str(photo), "--force"]) == 2
    assert "was not written by this program" in capsys.readouterr().err and photo.read_bytes() == b"\x89PNG the user's"
    victim.write_bytes(target.read_bytes())  # one of ours, behind a link
    (table / "link.png").symlink_to(victim)
    with pytest.raises(InputError, match="link.png is a symbolic link: give another file name"):
        plot_sweep(table, "normV", target=table / "link.png", force=True)
    assert victim.read_bytes() == target.read_bytes()


def test_a_log_axis_is_refused_where_a_value_is_not_positive_before_anything_is_drawn(tmp_path, capsys):
    """matplotlib leaves every value ≤ 0 off a logarithmic axis without a word: an empty image (or a
    curve cut short) that reads as complete. Refused, naming the column and its smallest value."""
    rows = [{"glue.gammaNu": 0.0, "folder": "a", "status": "completed", "normV": 2.0, "contactForce": -3.0},
            {"glue.gammaNu": 1.0, "folder": "b", "status": "completed", "normV": 1.0, "contactForce": 4.0}]
    write_table(tmp_path / "sweep.csv", rows, ["glue.gammaNu"])
    for y, log, words in (("contactForce", "y", ["--log y: contactForce goes down to -3", "without --log y"]),
                          ("normV", "x", ["--log x: glue.gammaNu goes down to 0", "without --log x"]),
                          ("contactForce", "xy", ["--log xy: glue.gammaNu goes down to 0"])):
        assert main(["plot", str(tmp_path), "--y", y, "--log", log]) == 2
        message = capsys.readouterr().err
        assert all(word in message for word in words) and len(message.strip().splitlines()) == 1, message
    assert main(["plot", str(tmp_path), "--y", "normV", "--log", "y"]) == 0  # all positive: drawn
    assert sorted(path.name for path in tmp_path.iterdir()) == ["normV-vs-glue.gammaNu.png", "sweep.csv"]


def test_a_log_axis_of_words_is_refused_not_drawn_linear(table):
    with pytest.raises(InputError, match=r"--log x: the values of body1.boundary.0.fy are not numbers .* without --log x"):
        plot_sweep(table, "normV", x="body1.boundary.0.fy", log="x")
    assert not list(table.glob("*.png"))


def test_an_image_into_a_new_folder_makes_it_and_a_file_on_the_way_is_refused_before_drawing(table, capsys):
    """As run --out makes its parents, plot --out does; a file where a folder should be is named."""
    deep = table / "figures" / "sweep" / "normV.svg"
    assert main(["plot", str(table), "--y", "normV", "--out", str(deep)]) == 0
    assert deep.read_text().startswith("<?xml")
    (table / "notes").write_text("the user's")
    assert main(["plot", str(table), "--y", "normV", "--out", str(table / "notes" / "more" / "n.png")]) == 2
    assert f"{table / 'notes'} is a file, not a folder" in capsys.readouterr().err
    assert (table / "notes").read_text() == "the user's"
