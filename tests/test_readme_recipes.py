"""The README's recipes run as written (issue 28, "A newcomer's first hour").

Every ```bash block of README.md but the first (the two set-up lines: a fresh virtual environment and
``pip install``) and its ```python block are run in fresh temporary folders with this environment's
``impactid`` first on ``PATH``. A bash block is run section by section (its paragraphs, separated by
blank lines; each section is self-contained), line by line as bash runs it, and each line must exit
with 0, print no ``impactid: error:`` line and leave the outputs it names (``--out``, ``--plots``,
``--json``). Before anything runs, the recipes are checked as text: every file an analysis line reads
is written by a line before it in its section (no placeholders such as ``REC1.h5``), and every file a
``synth`` line writes is read by a line after it. The rig P joint estimate must separate beta and n
(the issue's recipe gave "NOT SEPARABLE").

The runs are slow (a few minutes on a loaded machine, more while numba compiles the simulators
once): marked ``slow``. The checks of the text, and of what the recipes' ``synth`` commands refuse,
are fast.
"""

from __future__ import annotations

import fnmatch
import json
import os
import re
import shlex
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from impactid.cli import main
from impactid.rigs.ball import TABLE_TENNIS, read_bounces
from impactid.rigs.ball.synth import DEFAULT_BOUNCE_LAW, synth_drop

README = Path(__file__).resolve().parents[1] / "README.md"

#: Suffixes of the files the recipes read and write.
DATA_SUFFIXES = (".h5", ".hdf5", ".csv", ".xlsx", ".xls", ".wav", ".json", ".toml", ".zip")

#: Options whose value is an output, not an input.
OUTPUT_OPTIONS = ("--out", "--plots")

#: Longest time one line may take [s] (the first run compiles a rig's simulator: about a minute on a
#: loaded machine).
LINE_TIMEOUT_S = 900

def _blocks(text: str) -> list[tuple[str, str]]:
    """The fenced code blocks of a Markdown text: ``(language, code)`` in order."""
    return [(m.group(1), m.group(2)) for m in re.finditer(r"^```(\w*)\n(.*?)^```", text, flags=re.M | re.S)]


def _sections(code: str) -> list[list[str]]:
    """The paragraphs of a bash block (separated by blank lines): lists of lines, comments kept."""
    sections: list[list[str]] = [[]]
    for line in code.splitlines():
        if line.strip():
            sections[-1].append(line)
        elif sections[-1]:
            sections.append([])
    return [s for s in sections if s]


def _commands(section: list[str]) -> list[str]:
    """The command lines of a section (not the comment-only lines)."""
    return [line for line in section if shlex.split(line, comments=True)]


def _readme_sections() -> list[list[str]]:
    blocks = [code for lang, code in _blocks(README.read_text(encoding="utf-8")) if lang == "bash"]
    assert len(blocks) >= 2, "README.md: expected the set-up block and the command-line recipes"
    return [s for code in blocks[1:] for s in _sections(code) if _commands(s)]


def _python_block() -> str:
    blocks = [code for lang, code in _blocks(README.read_text(encoding="utf-8")) if lang == "python"]
    assert len(blocks) == 1, f"README.md: expected one python block, found {len(blocks)}"
    return blocks[0]


def _outputs(tokens: list[str]) -> list[str]:
    """The paths a command line writes (the values of ``--out`` and ``--plots``)."""
    return [tokens[i + 1] for i, t in enumerate(tokens[:-1]) if t in OUTPUT_OPTIONS]


def _inputs(tokens: list[str]) -> list[str]:
    """The files and folders a command line reads: arguments with a data suffix or a trailing ``/``
    that are no option's output."""
    out = []
    for i, t in enumerate(tokens):
        if t.startswith("-") or (i and tokens[i - 1] in OUTPUT_OPTIONS):
            continue
        if t.lower().endswith(DATA_SUFFIXES) or t.endswith("/"):
            out.append(t)
    return out


def _written_before(path: str, written: list[str]) -> bool:
    """Whether ``path`` (a file, a folder ``x/`` or a shell pattern ``track*.csv``) is one of ``written``,
    holds one of them or matches one."""
    folder = path.rstrip("/") + "/"
    return any(w == path or w.startswith(folder) or fnmatch.fnmatchcase(w, path) for w in written)


def _is_synth(tokens: list[str]) -> bool:
    return "synth" in tokens[1:3]


def _section_id(section: list[str]) -> str:
    """A test id from the section's heading comment: its words before ``:`` and two after."""
    head, _, rest = section[0].lstrip("# ").partition(":")
    words = re.sub(r"[^A-Za-z0-9]+", " ", head.split("(")[0]).split() + rest.split()[:2]
    return "-".join(words).lower()


SECTIONS = _readme_sections()


def test_readme_has_the_recipes():
    """The command-line recipes cover every analysis the README's table lists, each fed by a ``synth``."""
    lines = [shlex.split(line, comments=True) for s in SECTIONS for line in _commands(s)]
    commands = {" ".join(t[1:3]) if t[1] in ("valvetrain", "drop", "tracks", "planar") else t[1]
                for t in lines if t[0] == "impactid"}
    for needed in ("estimate", "events", "info", "campaign", "synth", "cam-fit", "restitution", "bifurcation",
                   "bounces", "drop fit", "valvetrain fit-tappet", "valvetrain fit-surge", "tracks analyse",
                   "planar fit", "planar predict"):
        assert needed in commands, f"README.md: no recipe runs 'impactid {needed}'"


@pytest.mark.parametrize("section", SECTIONS, ids=[_section_id(s) for s in SECTIONS])
def test_recipes_are_fed_by_the_lines_before_them(section):
    """As text: no placeholder input (every file read is written earlier in the section), every
    ``synth`` output is read later, and no file is written twice."""
    written: list[str] = []
    lines = [shlex.split(line, comments=True) for line in _commands(section)]
    for k, tokens in enumerate(lines):
        assert tokens[0] == "impactid", f"not an impactid command: {' '.join(tokens)}"
        for path in _inputs(tokens):
            assert _written_before(path, written), f"{' '.join(tokens)}: reads {path}, which no line before it makes"
        outputs = _outputs(tokens)
        files = [o for o in outputs if not o.endswith("/")]
        assert not set(files) & set(written), f"{' '.join(tokens)}: writes {files} again"
        if _is_synth(tokens):
            assert outputs, f"{' '.join(tokens)}: a synth line without --out"
            later = [p for t in lines[k + 1:] for p in _inputs(t)]
            assert any(_written_before(p, outputs) or p == outputs[0] or outputs[0].startswith(p.rstrip("/") + "/")
                       for p in later), f"{' '.join(tokens)}: nothing after it reads {outputs[0]}"
        written += outputs


def _environment() -> dict[str, str]:
    env = dict(os.environ)
    env["PATH"] = str(Path(sys.executable).parent) + os.pathsep + env.get("PATH", "")
    env.setdefault("NUMBA_NUM_THREADS", "1")
    env.setdefault("MPLBACKEND", "Agg")
    env.pop("PYTHONPATH", None)  # the environment's installed impactid, as a reader of the README has it
    return env


def _check_outputs(line: str, tokens: list[str], stdout: str, cwd: Path) -> None:
    """The outputs a line names exist and hold a result."""
    for option, path in zip(tokens, tokens[1:]):
        if option not in OUTPUT_OPTIONS:
            continue
        target = cwd / path
        assert target.exists(), f"{line}: wrote no {path}"
        if target.is_dir():
            assert any(target.iterdir()), f"{line}: {path} is empty"
        else:
            assert target.stat().st_size > 0, f"{line}: {path} is empty"
            if target.suffix == ".json":
                json.loads(target.read_text())
    if "--json" in tokens:
        json.loads(stdout)
    else:
        assert stdout.strip() or _outputs(tokens), f"{line}: printed nothing and wrote nothing"


def _check_joint_estimate(tokens: list[str], cwd: Path) -> None:
    """Rig P's joint estimate over two operating points tells beta from n (the issue's recipe did not)."""
    if tokens[1] != "estimate" or "--out" not in tokens:
        return
    recordings = [t for t in _inputs(tokens) if t.endswith(".h5")]
    if len(recordings) < 2:
        return
    result = json.loads((cwd / tokens[tokens.index("--out") + 1]).read_text())
    assert result["statistics"]["separable"], f"joint estimate: beta and n not separable ({result['notes']})"


@pytest.mark.slow
@pytest.mark.parametrize("section", SECTIONS, ids=[_section_id(s) for s in SECTIONS])
def test_readme_command_recipes_run(section, tmp_path):
    """Each command line of the section, in a fresh folder, exits 0 with its outputs (not a refusal)."""
    env = _environment()
    log = []
    for line in _commands(section):
        tokens = shlex.split(line, comments=True)
        start = time.perf_counter()
        proc = subprocess.run(["bash", "-c", line], cwd=tmp_path, env=env, capture_output=True, text=True,
                              timeout=LINE_TIMEOUT_S, stdin=subprocess.DEVNULL)
        log.append(f"{time.perf_counter() - start:6.1f} s  {' '.join(tokens)}")
        assert proc.returncode == 0 and "impactid: error:" not in proc.stderr, (
            f"{line}\nexit {proc.returncode}\n{proc.stderr[-3000:]}")
        _check_outputs(line, tokens, proc.stdout, tmp_path)
        _check_joint_estimate(tokens, tmp_path)
    print("\n".join(log))


@pytest.mark.slow
def test_readme_python_block_runs(tmp_path):
    """The Python block, as written, in a fresh folder: it runs and its estimates are results."""
    code = _python_block()
    proc = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=_environment(), capture_output=True,
                          text=True, timeout=3 * LINE_TIMEOUT_S, stdin=subprocess.DEVNULL)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "NOT SEPARABLE" not in proc.stdout, proc.stdout
    for expected in ("beta", "e0", "gamma"):
        assert expected in proc.stdout, f"the Python block printed no {expected!r}:\n{proc.stdout[-3000:]}"


# ---- the synth commands the recipes use: what they refuse (fast: before any computation) ----------


@pytest.mark.parametrize("argv,message", [
    (["synth", "--rig", "flat-follower", "--rpm", "110", "--restitution", "0.6"], "below the detachment speed"),
    (["synth", "--rig", "flat-follower", "--rpm", "130", "--beta", "3e9"], "argument --beta: not an option"),
    (["synth", "--rig", "bouncing-ball", "--noise", "0.01"], "--jitter"),
    (["synth", "--rig", "bouncing-ball", "--duration", "3"], "argument --duration: not an option"),
    (["synth", "--rig", "golf", "--ball", "pingpong"], "argument --ball"),
    (["synth", "--rig", "bouncing-ball", "--height", "0.001"], "argument --height"),
    (["synth", "--rig", "bouncing-ball", "--bounce-law", "0.5,0.5"], "argument --bounce-law"),
    (["synth", "--rig", "bouncing-ball", "--jitter", "1"], "argument --jitter"),
], ids=["flat-law-below-detachment", "flat-foreign", "ball-noise", "ball-duration", "ball-contradicts-rig",
        "ball-height", "ball-law", "ball-jitter"])
def test_synth_refusals(argv, message, tmp_path, capsys):
    """Each refusal is one ``impactid: error:`` line naming the argument, with exit 2 and no file."""
    out = tmp_path / ("x.h5" if "flat-follower" in argv else "x.csv")
    assert main([*argv, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("impactid: error:") and "\n" not in err and message in err, err
    assert not out.exists()


def test_ball_synth_refuses_an_unknown_suffix(tmp_path, capsys):
    assert main(["synth", "--rig", "bouncing-ball", "--out", str(tmp_path / "drop.h5")]) == 2
    assert "argument --out: a drop is written as .csv, .xlsx, .wav" in capsys.readouterr().err


@pytest.mark.parametrize("suffix", [".csv", ".xlsx", ".wav"])
def test_ball_synth_writes_what_bounces_reads(suffix, tmp_path):
    """``impactid synth --rig bouncing-ball`` writes the times ``read_bounces`` reads back (the audio's
    clicks within a millisecond of the true impacts)."""
    out = tmp_path / f"drop{suffix}"
    assert main(["synth", "--rig", "pingpong", "--height", "0.2", "--seed", "3", "--out", str(out)]) == 0
    law, params = DEFAULT_BOUNCE_LAW
    drop = synth_drop(law, params, seed=3, ball=TABLE_TENNIS, height=0.2)
    times = read_bounces(out).times
    if suffix == ".wav":
        assert times.size == drop.true_times.size
        assert np.max(np.abs(times - drop.true_times)) < 1e-3
    else:
        assert np.allclose(times, drop.times, atol=1e-9)
