"""Cold start of a fresh installation: the first ``impactid estimate --example`` against the warm one (issue 27).

A fresh virtual environment, ``pip install`` of this checkout (not editable: the package lands in
site-packages, with no numba cache), an empty user cache folder (``XDG_CACHE_HOME`` pointed at a new
folder: no example recordings either), then, each in a fresh process:

1. the install (wall time, and the CPU time of pip and its children);
2. the first ``impactid estimate --example``, stderr on a pseudo-terminal: it generates the two
   example recordings and compiles what the installation did not (the first run of a new user);
   CPU time (user + system of the process and its children), wall time, and the longest time
   stdout and stderr both stayed silent;
3. the same command again (warm: kernels and recordings cached), on a terminal and on pipes;
4. ``impactid --help`` and ``python -c "import impactid"``: medians of five.

Targets (issue 27): the first run costs at most 15 s more CPU than the warm run, and it is never
silent for more than 2 s; ``impactid --help`` at most 0.3 s and ``import impactid`` at most 0.5 s
(docs/performance_startup.md). Each is printed as PASS or MISS. Run:
``python benchmarks/bench_cold_start.py`` (writes ``docs/performance_cold_start.md``; ``--no-page``:
print only; ``--venv DIR``: an existing environment with impactid installed, its caches emptied
instead of reinstalling).
"""

from __future__ import annotations

import argparse
import os
import pty
import re
import resource
import selectors
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from pages import BenchmarkPage  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "performance_cold_start.md"

#: Targets: extra CPU of the first run [s], longest silence [s], --help and import medians [s].
EXTRA_CPU_S, SILENCE_S, HELP_S, IMPORT_S = 15.0, 2.0, 0.3, 0.5

PAGE_INTRO = """\
A fresh virtual environment with this checkout installed (`pip install .`, which compiles rig P's
kernels into the package: docs/simulator.md, "Kernels compiled at installation"), an empty user
cache folder, then the first `impactid estimate --example` (which generates the two example
recordings, and compiles whatever the installation did not bring), the warm one, `impactid --help`
and `import impactid`, each in a fresh process. CPU is user + system time of the process and its
children: on a shared machine it moves less with the load than the wall time. "Silent" is the
longest time during which nothing reached the user: the first and warm runs have stderr on a
pseudo-terminal, as in a shell (the status line and the progress bars are drawn only on a
terminal); the last run has both streams on pipes, as in a log, where the command prints only its
result."""


@dataclass(frozen=True)
class Run:
    """One command's measurements: exit status, wall [s], CPU of its process tree [s], longest silence [s]."""

    code: int
    wall: float
    cpu: float
    silent: float
    stderr: str


def run(command: list[str], env: dict[str, str], terminal: bool = False) -> Run:
    """Run ``command``, reading its stdout and stderr as they come (for the longest silence).

    ``terminal``: stderr is a pseudo-terminal, as in a user's shell (the status line and the progress
    bars of :mod:`impactid._status` and :mod:`impactid.compilation` are drawn only on a terminal);
    otherwise both are pipes, as in a log or CI.
    """
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = last = time.perf_counter()
    silent = 0.0
    err = bytearray()
    if terminal:
        master, slave = pty.openpty()
        proc = subprocess.Popen(command, env=env, stdout=subprocess.PIPE, stderr=slave)
        os.close(slave)
        err_source = master
    else:
        proc = subprocess.Popen(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        err_source = proc.stderr.fileno()
    selector = selectors.DefaultSelector()
    selector.register(proc.stdout.fileno(), selectors.EVENT_READ, "out")
    selector.register(err_source, selectors.EVENT_READ, "err")
    open_streams = 2
    while open_streams:
        for key, _ in selector.select():
            try:
                data = os.read(key.fd, 65536)
            except OSError:  # a pseudo-terminal whose other side closed
                data = b""
            now = time.perf_counter()
            if not data:
                selector.unregister(key.fd)
                open_streams -= 1
                continue
            silent, last = max(silent, now - last), now
            if key.data == "err":
                err += data
    proc.wait()
    if terminal:
        os.close(master)
    end = time.perf_counter()
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return Run(proc.returncode, end - start, cpu, max(silent, end - last), err.decode(errors="replace"))


def verdict(ok: bool) -> str:
    return "PASS" if ok else "MISS"


def median_wall(command: list[str], env: dict[str, str], repeat: int = 5) -> float:
    run(command, env)  # file-system cache and byte-code
    return statistics.median(run(command, env).wall for _ in range(repeat))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--venv", type=Path, help="an existing environment with impactid installed (no install)")
    parser.add_argument("--no-page", action="store_true", help="print only (do not write the page)")
    args = parser.parse_args(argv)
    with BenchmarkPage(None if args.no_page else PAGE, "Performance: the cold start", PAGE_INTRO):
        return measure(args)


def measure(args) -> int:
    with tempfile.TemporaryDirectory(prefix="impactid-cold-") as scratch:
        scratch = Path(scratch)
        venv = args.venv or scratch / "venv"
        env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "IMPACTID_CACHE_DIR",
                                                                  "PYTHONPATH", "VIRTUAL_ENV")}
        env["XDG_CACHE_HOME"] = str(scratch / "user-cache")  # no example recordings, no user-wide numba cache
        if args.venv is None:
            print("== install: python -m venv, pip install . ==")
            made = run([sys.executable, "-m", "venv", str(venv)], env)
            pip = run([str(venv / "bin" / "python"), "-m", "pip", "install", "--quiet", str(ROOT)], env)
            if made.code or pip.code:
                print(f"install failed ({made.code}, {pip.code}):\n{made.stderr}{pip.stderr}")
                return 1
            print(f"install: {made.wall + pip.wall:6.1f} s wall, {made.cpu + pip.cpu:6.1f} s CPU (venv + pip, "
                  "downloads included)")
        else:
            print(f"== environment {venv} (caches emptied, no install) ==")
            site = subprocess.run([str(venv / "bin" / "python"), "-c", "import impactid, os; "
                                   "print(os.path.dirname(impactid.__file__))"], env=env, capture_output=True,
                                  text=True, check=True).stdout.strip()
            for cache in Path(site).rglob("__pycache__"):
                for f in [*cache.glob("*.nbi"), *cache.glob("*.nbc")]:
                    f.unlink()
        impactid = [str(venv / "bin" / "impactid")]
        python = str(venv / "bin" / "python")
        print(f"\n== impactid estimate --example (load average {os.getloadavg()[0]:.1f}) ==")
        first = run([*impactid, "estimate", "--example"], env, terminal=True)
        warm = run([*impactid, "estimate", "--example"], env, terminal=True)
        warm_log = run([*impactid, "estimate", "--example"], env)
        if first.code or warm.code or warm_log.code:
            print(f"the example failed ({first.code}, {warm.code}, {warm_log.code}):\n"
                  f"{first.stderr[-2000:]}{warm.stderr[-2000:]}{warm_log.stderr[-2000:]}")
            return 1
        for label, r in (("first (stderr a terminal)", first), ("warm (stderr a terminal)", warm),
                         ("warm (stdout, stderr pipes)", warm_log)):
            print(f"{label:30s}: {r.cpu:6.1f} s CPU, {r.wall:6.1f} s wall, longest silence {r.silent:5.1f} s")
        shown = re.sub(r"\x1b\[K", "", first.stderr).replace("\r", "\n")
        notices = sorted({line.split(" (first use")[0] for line in shown.splitlines()
                          if line.startswith("impactid: compiling")})
        print("first run's compile notices:" if notices else "first run's compile notices: none (nothing compiled)")
        for line in notices:
            print(f"  {line}")
        print(f"\n== start-up, medians of 5 (load average {os.getloadavg()[0]:.1f}) ==")
        help_s = median_wall([*impactid, "--help"], env)
        import_s = median_wall([python, "-c", "import impactid"], env)
        print(f"impactid --help        : {help_s:6.3f} s")
        print(f"python -c 'import impactid': {import_s:6.3f} s")
        extra = first.cpu - warm.cpu
        print("\n== targets ==")
        print(f"{verdict(extra <= EXTRA_CPU_S)}  first run at most {EXTRA_CPU_S:.0f} s more CPU than the warm run: "
              f"{extra:.1f} s more")
        print(f"{verdict(first.silent <= SILENCE_S)}  first run never silent for more than {SILENCE_S:.0f} s "
              f"(on a terminal): longest silence {first.silent:.1f} s")
        print(f"{verdict(warm.silent <= SILENCE_S)}  warm run never silent for more than {SILENCE_S:.0f} s "
              f"(on a terminal): longest silence {warm.silent:.1f} s")
        print(f"note  in a log (pipes, no status line) the warm run is silent for {warm_log.silent:.1f} s "
              "until it prints its result")
        print(f"{verdict(help_s <= HELP_S)}  impactid --help at most {HELP_S} s: {help_s:.3f} s")
        print(f"{verdict(import_s <= IMPORT_S)}  import impactid at most {IMPORT_S} s: {import_s:.3f} s")
        if args.venv is None:
            shutil.rmtree(venv, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
