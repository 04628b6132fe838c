"""Operating-system errors become one sentence naming the path and the fix, for run, validate and
convert; a run that fails or is stopped before its first checkpoint leaves no folder behind.

A read-only folder, a read-only mount and a full disk are simulated by making every file or folder
created under one root fail with that errno (tests may run as root, where permissions do not bite).
"""

import errno
import json
import os
from pathlib import Path

import pytest
from click.testing import CliRunner

from erosim.cli import cli
from erosim.core.errors import os_error_message

ERRNOS = {errno.EACCES: "Permission denied", errno.EROFS: "read-only file system", errno.ENOSPC: "No space left"}


@pytest.fixture
def failing_under(monkeypatch):
    """``failing_under(root, code, match="")``: ``root`` exists, and creating a file or folder in it
    whose path contains ``match`` fails with ``code``."""

    def install(root: Path, code: int, match: str = ""):
        real_open, real_mkdir = os.open, os.mkdir
        if not match:
            root.mkdir(parents=True)
        root = str(root) + os.sep

        def hit(path) -> bool:
            p = os.fsdecode(path)
            return p.startswith(root) and match in p

        def fake_open(path, flags, *args, **kwargs):
            if flags & os.O_CREAT and hit(path):
                raise OSError(code, os.strerror(code), os.fsdecode(path))
            return real_open(path, flags, *args, **kwargs)

        def fake_mkdir(path, *args, **kwargs):
            if hit(path):
                raise OSError(code, os.strerror(code), os.fsdecode(path))
            return real_mkdir(path, *args, **kwargs)

        monkeypatch.setattr(os, "open", fake_open)
        monkeypatch.setattr(os, "mkdir", fake_mkdir)

    return install


def _one_sentence(result) -> str:
    lines = [ln for ln in result.output.strip().splitlines() if ln.strip()]
    assert result.exit_code not in (0, 1), result.output  # 1 would be an uncaught exception
    assert "Traceback" not in result.output
    assert len(lines) == 1 and lines[0].startswith("erosim: error: "), result.output
    return lines[0]


@pytest.mark.parametrize("code", sorted(ERRNOS))
def test_run_into_a_folder_that_cannot_be_written(tmp_path, failing_under, code):
    failing_under(tmp_path / "ro", code)
    out = tmp_path / "ro" / "x"
    result = CliRunner().invoke(cli, ["--quiet", "run", "dam-break-2d", "--set", "run.t_end=0.01", "--out", str(out)])
    line = _one_sentence(result)
    assert ERRNOS[code].lower() in line.lower() and str(out) in line
    assert not out.exists()


def test_a_full_disk_while_writing_frames_names_the_frame_and_keeps_what_was_written(tmp_path, failing_under):
    out = tmp_path / "run"
    failing_under(out, errno.ENOSPC, match="frame_00001")
    args = ["--quiet", "run", "dam-break-2d", "--set", "run.t_end=0.05", "--set", "run.output_interval=0.01"]
    result = CliRunner().invoke(cli, [*args, "--out", str(out)])
    line = _one_sentence(result)
    assert "No space left" in line and "frame_00001" in line and ".part" not in line
    report = json.loads((out / "report.json").read_text())  # the run had started: its report says why it stopped
    assert report["status"] == "failed" and "frame_00001" in report["error"]
    assert (out / "particles" / "frame_00000.vtp").is_file()
    assert not list(out.rglob("*.part"))  # no half-written file


def test_a_disk_too_full_for_the_report_leaves_no_folder(tmp_path, failing_under):
    out = tmp_path / "run"
    failing_under(out, errno.ENOSPC, match=".vtp")  # the first frame fails, and so would everything
    failing_under(out, errno.ENOSPC, match="report")
    result = CliRunner().invoke(cli, ["--quiet", "run", "dam-break-2d", "--set", "run.t_end=0.01", "--out", str(out)])
    line = _one_sentence(result)
    assert "No space left" in line
    assert not out.exists()


@pytest.mark.parametrize("code", sorted(ERRNOS))
def test_convert_to_a_folder_that_cannot_be_written(tmp_path, failing_under, code):
    failing_under(tmp_path / "ro", code)
    dst = tmp_path / "ro" / "out.tif"
    result = CliRunner().invoke(cli, ["convert", "sample:jacksboro", str(dst)])
    line = _one_sentence(result)
    assert ERRNOS[code].lower() in line.lower() and str(dst) in line


@pytest.mark.parametrize("code", sorted(ERRNOS))
def test_validate_into_a_folder_that_cannot_be_written(tmp_path, failing_under, code):
    failing_under(tmp_path / "ro", code)
    out = tmp_path / "ro" / "v"
    args = ["--quiet", "validate", "hydrostatic", "--resolution", "coarse", "--out", str(out)]
    line = _one_sentence(CliRunner().invoke(cli, args))
    assert ERRNOS[code].lower() in line.lower() and str(out) in line


def test_a_file_where_the_run_folder_should_be(tmp_path):
    blocker = tmp_path / "afile"
    blocker.write_text("x")
    result = CliRunner().invoke(cli, ["--quiet", "run", "dam-break-2d", "--out", str(blocker / "x")])
    line = _one_sentence(result)
    assert "part of that path is a file, not a folder" in line and str(blocker) in line
    result = CliRunner().invoke(cli, ["--quiet", "run", "dam-break-2d", "--out", str(blocker)])
    assert result.exit_code == 2 and "is a file" in result.output  # click's own check of --out
    assert blocker.read_text() == "x"


def test_errors_found_while_building_a_run_leave_no_folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for args in (["rain-erosion", "--set", "terrain.file=fake.tif"], ["dam-break-2d", "--set", "sph.dt=1.0"]):
        result = CliRunner().invoke(cli, ["--quiet", "run", *args])
        _one_sentence(result)
    assert not (tmp_path / "runs").exists() or not any((tmp_path / "runs").iterdir())


def test_ctrl_c_before_the_first_step_leaves_no_folder_and_says_so(tmp_path, monkeypatch):
    from erosim.scenarios.sph import build as sph_build

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(sph_build, "setup", interrupted)
    out = tmp_path / "x"
    result = CliRunner().invoke(cli, ["--quiet", "run", "dam-break-2d", "--out", str(out)])
    assert result.exit_code == 130
    assert "Interrupted before the first step" in _one_sentence_any_code(result)
    assert not out.exists()


def _one_sentence_any_code(result) -> str:
    lines = [ln for ln in result.output.strip().splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in result.output, result.output
    return lines[0]


@pytest.mark.parametrize(
    "code, words",
    [
        (errno.EACCES, "Permission denied for 'p'"),
        (errno.EPERM, "Permission denied for 'p'"),
        (errno.EROFS, "read-only file system"),
        (errno.ENOSPC, "No space left on the disk holding 'p'"),
        (errno.EDQUOT, "No space left"),
        (errno.ENOTDIR, "part of that path is a file"),
        (errno.EISDIR, "is a folder, not a file"),
        (errno.ENOENT, "File not found: 'p'"),
        (errno.EIO, "Input/output error for 'p'"),
    ],
)
def test_each_os_error_class_has_its_sentence(code, words):
    line = os_error_message(OSError(code, os.strerror(code), "p"))
    assert words in line and line.endswith(".") and "\n" not in line


def test_an_os_error_without_a_path_keeps_its_own_message():
    line = os_error_message(OSError("Free disk space available is 10 bytes, whereas 2000 are at least necessary."))
    assert line.startswith("Free disk space available is 10 bytes") and "\n" not in line and line.endswith(".")


def test_a_run_whose_report_cannot_be_written_keeps_its_checkpoint_and_says_how_to_resume(tmp_path, monkeypatch):
    from erosim.io.runfolder import RunFolder

    def no_space(self, *args, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(self.path / "report.json"))

    monkeypatch.setattr(RunFolder, "write_report", no_space)
    out = tmp_path / "run"
    result = CliRunner().invoke(cli, ["--quiet", "run", "dam-break-2d", "--set", "run.t_end=0.01", "--out", str(out)])
    line = _one_sentence(result)
    assert "No space left" in line and f"erosim run --resume {out}" in line
    assert (out / "checkpoint").is_dir()
