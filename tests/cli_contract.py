"""The command line's failure contract, as the hostile-input tests check it."""

from __future__ import annotations

from impactid.cli import main


def fails_with_one_line(capsys, argv, *needles, code=2) -> str:
    """Run ``argv``; it must exit ``code`` with exactly one error line, last, containing ``needles``."""
    assert main(argv) == code
    err = capsys.readouterr().err
    errors = [line for line in err.splitlines() if line.startswith("impactid: error:")]
    assert len(errors) == 1, err
    assert err.rstrip("\n").splitlines()[-1] == errors[0] and "Traceback" not in err
    for needle in needles:
        assert needle in errors[0], (needle, errors[0])
    return errors[0]
