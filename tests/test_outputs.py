"""The commands that write outside a run folder (compare, plot, render --out, the studies, bench,
reference, gallery) take a new folder or refuse; with --force they replace only what they wrote
themselves, and never through a symbolic link (issue 32, item 2; orchestrate/outputs.py). These
checks need no run: a command refuses before it computes anything."""
import json
import os

import pytest

from orchestrate.cli import main
from orchestrate.freefem import REPO
from orchestrate.outputs import RECORD, OutputError, claim_folder, refuse_file

pytestmark = pytest.mark.unit

PAPER = REPO / "scenes" / "paper.toml"


@pytest.fixture
def cli(capsys, monkeypatch):
    """python -m orchestrate in this process, from the repository root: (exit code, stderr)."""
    monkeypatch.chdir(REPO)

    def call(*args):
        code = main([os.fsdecode(arg) for arg in args])
        return code, capsys.readouterr().err
    return call


def test_a_folder_is_taken_new_or_empty_and_replaced_only_by_its_own_command(tmp_path):
    out = tmp_path / "c"
    claim_folder(out, "compare", ["report.txt", "history.png"], force=False)
    assert json.loads((out / RECORD).read_text())["files"] == ["history.png", "report.txt"]
    (out / "report.txt").write_text("ours")
    with pytest.raises(OutputError, match=r"c exists \(written by `python -m orchestrate compare` before\): pass "
                                          r"--force to replace its files, or choose another --out"):
        claim_folder(out, "compare", ["report.txt"], force=False)
    with pytest.raises(OutputError, match=r"holds the files of `python -m orchestrate compare`, not of "
                                          r"`python -m orchestrate render`"):
        claim_folder(out, "render", ["history.png"], force=True)
    claim_folder(out, "compare", ["report.txt", "history.png"], force=True)
    assert sorted(os.listdir(out)) == [RECORD]
    empty = tmp_path / "empty"
    empty.mkdir()
    assert claim_folder(empty, "study hertz", ["README.md"], force=False) == empty


def test_force_unlinks_a_link_among_its_files_and_refuses_anything_else(tmp_path):
    out, victim = tmp_path / "c", tmp_path / "victim.png"
    victim.write_bytes(b"the user's")
    claim_folder(out, "compare", ["history.png"], force=False, folders=("runs",))
    (out / "history.png").symlink_to(victim)
    (out / "runs").mkdir()
    (out / "runs" / "kept").write_text("a run")
    claim_folder(out, "compare", ["history.png"], force=True, folders=("runs",))
    assert victim.read_bytes() == b"the user's" and not os.path.lexists(out / "history.png")
    assert (out / "runs" / "kept").exists()  # the runs are reused: the runner checks each
    (out / "notes.txt").write_text("the user's")
    with pytest.raises(OutputError, match=r"also holds notes.txt, which `python -m orchestrate compare` did not write: "
                                          r"--force replaces only its own files; move those away"):
        claim_folder(out, "compare", ["history.png"], force=True)
    assert (out / "notes.txt").read_text() == "the user's"


def test_a_folder_of_a_user_or_a_link_is_refused_with_force(tmp_path):
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "report.txt").write_text("the user's")
    with pytest.raises(OutputError, match=r"mine exists and holds files no orchestrate command recorded writing "
                                          rf"\(report.txt; no {RECORD}\): choose a new or empty folder"):
        claim_folder(mine, "compare", ["report.txt"], force=True)
    (tmp_path / "link").symlink_to(mine)
    with pytest.raises(OutputError, match="link is a symbolic link: give a folder's own path"):
        claim_folder(tmp_path / "link", "compare", ["report.txt"], force=True)
    assert (mine / "report.txt").read_text() == "the user's" and sorted(os.listdir(mine)) == ["report.txt"]


def test_a_single_file_is_replaced_only_with_force_when_it_holds_its_mark_and_never_a_link(tmp_path):
    target, victim = tmp_path / "page.md", tmp_path / "victim.md"
    refuse_file(target, False, "MARK")  # none yet
    target.write_text("a MARK of ours")
    with pytest.raises(OutputError, match=r"page.md exists: pass --force to replace it \(only a file this program "
                                          r"wrote\), or choose another --out"):
        refuse_file(target, False, "MARK")
    refuse_file(target, True, "MARK")
    target.write_text("the user's")
    with pytest.raises(OutputError, match=r"was not written by this program \(it lacks 'MARK'\)"):
        refuse_file(target, True, "MARK")
    victim.write_text("a MARK, but behind a link")
    target.unlink()
    target.symlink_to(victim)
    with pytest.raises(OutputError, match="page.md is a symbolic link: give another file name"):
        refuse_file(target, True, "MARK")


def user_folder(tmp_path):
    folder = tmp_path / "mine"
    folder.mkdir()
    (folder / "README.md").write_text("the user's")
    return folder


@pytest.mark.parametrize("command", [["compare", "nowhere-a", "nowhere-b"], ["study", "convergence", PAPER],
                                     ["study", "stability"], ["study", "hertz"], ["bench"],
                                     ["render", "results/paper"]],
                         ids=lambda command: " ".join(map(str, command[:2])))
def test_every_folder_writer_refuses_a_users_folder_before_it_computes(tmp_path, cli, command):
    """A folder of someone else's files is refused, --force or not, before any run (a study takes
    minutes to hours: the old code ran it all and then wrote over README.md)."""
    folder = user_folder(tmp_path)
    for force in ([], ["--force"]):
        code, err = cli(*command, "--out", folder, *force)
        assert code == 2 and f"--out {folder} exists and holds files no orchestrate command recorded writing " \
                             "(README.md" in err, err
    assert (folder / "README.md").read_text() == "the user's" and os.listdir(folder) == ["README.md"]


def test_the_reference_page_replaces_only_a_page_it_generated(tmp_path, cli):
    page = tmp_path / "format.md"
    assert cli("reference", "--out", page)[0] == 0
    code, err = cli("reference", "--out", page)
    assert code == 2 and "exists: pass --force to replace it" in err
    assert cli("reference", "--out", page, "--force")[0] == 0
    page.write_text("the user's notes")
    code, err = cli("reference", "--out", page, "--force")
    assert code == 2 and "was not written by this program" in err
    assert page.read_text() == "the user's notes"


def test_the_gallery_refuses_an_existing_run_folder_unless_forced_before_any_run(tmp_path, cli):
    (tmp_path / "peel").mkdir()
    (tmp_path / "peel" / "summary.json").write_text("{}")
    code, err = cli("gallery", "paper", "peel", "--out", tmp_path)
    assert code == 1 and f"{tmp_path / 'peel'} exists: choose another --out or pass --force" in err
    assert not (tmp_path / "paper").exists()  # refused before the first scene ran


# --- a second round as an attacker (issue 32): names read from a record never become paths -------

@pytest.mark.parametrize("name", ["../victim.txt", "/ABSOLUTE", "sub/../../victim.txt", "..", ""])
def test_a_record_naming_a_path_outside_its_folder_is_no_record_and_deletes_nothing(tmp_path, name):
    """Was: --force unlinked every name of made-by.json, `../victim.txt` and absolute paths too."""
    victim = tmp_path / "victim.txt"
    victim.write_text("the user's")
    out = tmp_path / "cmp"
    claim_folder(out, "compare", ["report.txt"], force=False)
    record = json.loads((out / RECORD).read_text())
    record["files"].append(name.replace("/ABSOLUTE", str(victim)))
    (out / RECORD).write_text(json.dumps(record))
    with pytest.raises(OutputError, match="holds files no orchestrate command recorded writing"):
        claim_folder(out, "compare", ["report.txt"], force=True)
    assert victim.read_text() == "the user's"


def test_a_file_named_as_an_image_is_replaced_only_when_it_is_one_of_ours(tmp_path):
    """Was: any file holding the words of the mark was taken for an image the package drew."""
    notes = tmp_path / "notes.png"
    notes.write_text("notes: written by python -m orchestrate\n")
    with pytest.raises(OutputError, match="was not written by this program"):
        refuse_file(notes, force=True, mark="written by python -m orchestrate")


def test_a_sweep_takes_only_a_new_folder_or_its_own(tmp_path):
    """Was: `sweep --out` an existing folder wrote over the user's sweep.csv without a word."""
    from orchestrate.outputs import claim_growing_folder

    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "sweep.csv").write_text("my table")
    with pytest.raises(OutputError, match="holds files no orchestrate command recorded writing"):
        claim_growing_folder(mine, "sweep", ["sweep.csv"], ["a-1"], (".partial",))
    assert (mine / "sweep.csv").read_text() == "my table"
    ours = tmp_path / "ours"
    claim_growing_folder(ours, "sweep", ["sweep.csv"], ["a-1"], (".partial",))
    (ours / "a-1").mkdir()
    (ours / "a-2.partial").mkdir()
    claim_growing_folder(ours, "sweep", ["sweep.csv"], ["a-2"], (".partial",))  # a later sweep adds its rows
    assert json.loads((ours / RECORD).read_text())["folders"] == ["a-1", "a-2"]
    (ours / "thesis.tex").write_text("the user's")
    with pytest.raises(OutputError, match="also holds thesis.tex"):
        claim_growing_folder(ours, "sweep", ["sweep.csv"], ["a-3"], (".partial",))


def test_run_force_replaces_a_run_folder_only_when_it_holds_nothing_else(tmp_path, cli):
    """Was: a folder holding a run.json (or summary.json) was deleted whole, the user's files in it too."""
    folder = tmp_path / "project"
    folder.mkdir()
    (folder / "run.json").write_text('{"mine": 1}')
    (folder / "thesis.tex").write_text("the user's")
    code, err = cli("run", PAPER, "--out", folder, "--force")
    assert code == 1 and "also thesis.tex, which no run writes" in err, err
    assert sorted(os.listdir(folder)) == ["run.json", "thesis.tex"]


def test_a_pipe_or_a_folder_named_as_an_image_is_foreign_and_never_read(tmp_path):
    """Was: a named pipe called p.png in a sweep folder made `sweep` wait for ever on reading it,
    and a folder called figs.png ended it with IsADirectoryError."""
    from orchestrate.outputs import claim_growing_folder

    folder = tmp_path / "sweep"
    claim_growing_folder(folder, "sweep", ["sweep.csv"], ["a-1"], (".partial",))
    os.mkfifo(folder / "p.png")
    (folder / "figs.png").mkdir()
    with pytest.raises(OutputError, match="also holds figs.png, p.png"):
        claim_growing_folder(folder, "sweep", ["sweep.csv"], ["a-1"], (".partial",))

