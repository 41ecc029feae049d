"""Cold start of the compiled kernels: the cache folder's choice, ``impactid warmup``'s command line and
the first-use notice (unit level: nothing is compiled but one tiny function)."""

from __future__ import annotations

import io
import sys
import time
from pathlib import Path

import pytest
from numba import njit

import impactid
from impactid import _cachedir, compilation
from impactid.cli import build_parser, cmd_warmup, main

# ---- where the kernels are cached ----------------------------------------------------------------


def test_an_explicit_numba_cache_dir_wins(tmp_path):
    env = {"NUMBA_CACHE_DIR": str(tmp_path / "n"), "IMPACTID_CACHE_DIR": str(tmp_path / "i")}
    choice = _cachedir.choose_kernel_cache(tmp_path, env)
    assert choice.folder is None and "NUMBA_CACHE_DIR" in choice.reason


def test_impactid_cache_dir_moves_the_kernels(tmp_path):
    choice = _cachedir.choose_kernel_cache(tmp_path, {"IMPACTID_CACHE_DIR": str(tmp_path / "c")})
    assert choice.folder == tmp_path / "c" / "numba"


def test_a_writable_installation_keeps_numbas_pycache(tmp_path):
    assert _cachedir.choose_kernel_cache(tmp_path, {}).folder is None


def test_a_read_only_installation_caches_in_the_users_cache(tmp_path, monkeypatch):
    package = tmp_path / "site-packages" / "impactid"
    package.mkdir(parents=True)
    monkeypatch.setattr(_cachedir.os, "access", lambda path, mode: "site-packages" not in str(path))
    choice = _cachedir.choose_kernel_cache(package, {"XDG_CACHE_HOME": str(tmp_path / "xdg")}, "linux")
    assert choice.folder == tmp_path / "xdg" / "impactid" / "numba" and "read-only" in choice.reason


def test_nothing_writable_falls_back_to_a_temporary_folder(tmp_path, monkeypatch):
    monkeypatch.setattr(_cachedir.os, "access", lambda path, mode: False)
    choice = _cachedir.choose_kernel_cache(tmp_path, {"XDG_CACHE_HOME": str(tmp_path / "xdg")}, "linux")
    assert "impactid-numba-cache" in str(choice.folder)


def test_the_users_cache_folder_is_the_platforms(tmp_path, monkeypatch):
    monkeypatch.setattr(Path, "home", classmethod(lambda cls: tmp_path))
    assert _cachedir.user_cache_root({}, "linux") == tmp_path / ".cache" / "impactid"
    assert _cachedir.user_cache_root({}, "darwin") == tmp_path / "Library" / "Caches" / "impactid"
    assert _cachedir.user_cache_root({"LOCALAPPDATA": str(tmp_path)}, "win32") == tmp_path / "impactid" / "Cache"
    assert _cachedir.user_cache_root({"XDG_CACHE_HOME": "/x"}, "linux") == Path("/x/impactid")
    assert _cachedir.user_cache_root({"IMPACTID_CACHE_DIR": "/y"}, "darwin") == Path("/y")


def test_import_sets_numba_cache_dir_from_impactid_cache_dir(tmp_path, monkeypatch):
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.delitem(sys.modules, "numba")  # as before numba's first import (restored afterwards)
    monkeypatch.setenv("IMPACTID_CACHE_DIR", str(tmp_path))
    impactid._numba_cache_fallback()
    assert impactid.os.environ["NUMBA_CACHE_DIR"] == str(tmp_path / "numba")


# ---- impactid warmup ------------------------------------------------------------------------------


def test_warmup_command_parses():
    args = build_parser().parse_args(["warmup", "--rig", "drop-impact"])
    assert args.func is cmd_warmup and args.rig == "drop-impact"
    assert build_parser().parse_args(["warmup"]).rig is None


def test_warmup_help_and_a_bad_rig(capsys):
    with pytest.raises(SystemExit) as stop:
        main(["warmup", "--help"])
    assert stop.value.code == 0
    out = capsys.readouterr().out
    assert "usage: impactid warmup" in out and "--rig" in out
    assert main(["warmup", "--rig", "no-such-rig"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("impactid: error: argument --rig") and err.count("\n") == 1


def test_warmup_of_a_rig_without_kernels(capsys):
    assert main(["warmup", "--rig", "bouncing-ball"]) == 0
    out = capsys.readouterr().out
    assert "numba cache:" in out and "bouncing-ball: nothing to compile" in out


# ---- the first-use notice ---------------------------------------------------------------------------

GROUP = compilation.KernelGroup("the test kernel", 2.0)


def test_notice_off_a_terminal_is_one_line_of_dots():
    stream = io.StringIO()
    notice = compilation.Notice(GROUP, stream=stream, tty=False, tick=0.01)
    notice.start()
    time.sleep(0.1)
    notice.finish()
    text = stream.getvalue()
    assert text.startswith("impactid: compiling the test kernel (first use; about 2 s, cached afterwards) ")
    assert text.count("\n") == 1 and text.endswith(" done in 0 s\n") and "." in text.split(")", 1)[1]


def test_notice_on_a_terminal_is_a_bar():
    stream = io.StringIO()
    ticks = iter([0.0, 1.0, 1.0, 1.0, 1.0, 2.5])
    notice = compilation.Notice(GROUP, stream=stream, tty=True, tick=10.0, clock=lambda: next(ticks))
    notice.start()
    notice.finish()
    text = stream.getvalue()
    assert "[" in text and "of about 2 s" in text and text.endswith(", done\n") and "\r" in text


def test_later_compilations_of_a_group_say_more():
    assert "more of the test kernel" in compilation.Notice(GROUP, first=False).header()


def test_bar_fills_at_the_expected_time():
    notice = compilation.Notice(GROUP)
    assert notice.bar(0.0, width=4) == "[----] 0 s of about 2 s"
    assert notice.bar(5.0, width=4) == "[####] 5 s of about 2 s"


def _tiny(x):
    return x + 1


def test_a_compilation_of_impactid_prints_the_notice_and_a_cache_hit_nothing(capsys, monkeypatch):
    monkeypatch.setenv("IMPACTID_COMPILE_NOTICE", "1")
    compilation.install()
    _tiny.__module__ = "impactid._tiny_for_the_test"
    tiny = njit(_tiny)
    assert tiny(1) == 2
    err = capsys.readouterr().err
    assert err.startswith("impactid: compiling impactid's compiled functions (first use; about 2 s")
    assert err.count("\n") == 1 and "done in" in err
    assert tiny(2) == 3  # compiled already: no notice
    assert capsys.readouterr().err == ""


def test_the_notice_can_be_turned_off(capsys, monkeypatch):
    monkeypatch.setenv("IMPACTID_COMPILE_NOTICE", "0")
    compilation.install()

    def other(x):
        return x * 2

    other.__module__ = "impactid._tiny_for_the_test"
    assert njit(other)(2) == 4
    assert capsys.readouterr().err == ""
    assert not compilation.notice_enabled({"IMPACTID_COMPILE_NOTICE": "off"})
    assert compilation.notice_enabled({})


def test_functions_outside_impactid_print_nothing(capsys, monkeypatch):
    monkeypatch.setenv("IMPACTID_COMPILE_NOTICE", "1")
    compilation.install()

    def third(x):
        return x - 1

    third.__module__ = "someone_else"
    assert njit(third)(2) == 1
    assert capsys.readouterr().err == ""
