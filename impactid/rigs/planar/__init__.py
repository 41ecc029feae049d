"""The planar-impact rig: impact laws with friction for a rigid body in the plane, from tables of impacts.

A rigid body (a mass and a radius of gyration) hits a surface at one contact; each impact is one row
of a table: the pre-impact state, the rows of the contact Jacobian and, when measured, the
post-impact velocity and the impulse (the layout of the planar impact dataset of Fazeli, Donlon,
Drumwright & Rodriguez 2017). The modules follow the data:

* :mod:`~impactid.rigs.planar.parameters`: the :class:`PlanarBody` (TOML rig files) and its preset;
* :mod:`~impactid.rigs.planar.table`: the table readers (:func:`read_pre_impact` reads no outcome);
* :mod:`~impactid.rigs.planar.laws`: the algebraic impact laws (Newton restitution with Coulomb
  friction and sticking; Chatterjee & Ruina 1998), vectorised NumPy functions;
* :mod:`~impactid.rigs.planar.identify`: the fits through :mod:`impactid.engine`, the law
  comparison, the prediction and its scoring;
* :mod:`~impactid.rigs.planar.commands` (``impactid planar fit``, ``impactid planar predict``) and
  :mod:`~impactid.rigs.planar.cli` (what they run).

See ``docs/planar_impacts.md``. Importing this package loads nothing of the rig: the names below are
imported from their modules on first use and :data:`MODEL` is built on first use.
"""

from __future__ import annotations

from impactid.rigs.base import RigModel, lazy_attributes

__all__ = ["LAWS", "MCUBE_ELLIPSE", "MODEL", "PlanarBody", "PlanarFitError", "PlanarImpacts", "PlanarLaw",
           "PlanarLawFit", "PlanarTableError", "fit_planar", "fit_planar_law", "get_law", "predict_planar",
           "read_impacts", "read_pre_impact", "score_predictions"]

#: The rig's commands by import path (:data:`MODEL`'s field, read by the registry without building
#: :data:`MODEL`); impactid's generic estimate takes no tables of impacts.
COMMANDS = "impactid.rigs.planar.commands"
ESTIMATION = None
ESTIMATE_ARGUMENTS = None

#: The names of the rig's presets, the default first (``MODEL.presets``).
PRESET_NAMES = ("mcube-ellipse",)

#: Where the public names live, imported on first use.
_LAZY = {
    **dict.fromkeys(("MCUBE_ELLIPSE", "PlanarBody"), "impactid.rigs.planar.parameters"),
    **dict.fromkeys(("PlanarImpacts", "PlanarTableError", "read_impacts", "read_pre_impact"),
                    "impactid.rigs.planar.table"),
    **dict.fromkeys(("LAWS", "PlanarLaw", "get_law"), "impactid.rigs.planar.laws"),
    **dict.fromkeys(("PlanarFitError", "PlanarLawFit", "fit_planar", "fit_planar_law", "predict_planar",
                     "score_predictions"), "impactid.rigs.planar.identify"),
}


def _measure(source, **options):
    """:func:`~impactid.rigs.planar.table.read_impacts` (imported on use: it loads pandas)."""
    from impactid.rigs.planar.table import read_impacts

    return read_impacts(source, **options)


def _model() -> RigModel:
    """The planar rigid body behind the rig-model protocol: no cam, no compiled kernel; its measurement
    model reads a table of impacts and its commands are ``impactid planar fit`` and ``impactid planar
    predict``. Built on first use of :data:`MODEL` (registered in :mod:`impactid.rigs.registry`)."""
    from impactid.rigs.planar.parameters import MODEL_NAME, PRESETS, PlanarBody

    return RigModel(
        name=MODEL_NAME,
        title="A rigid body's impacts in the plane with friction, from tables of pre- and post-impact states "
              "(Fazeli, Donlon, Drumwright & Rodriguez 2017)",
        citation="",
        parameters=PlanarBody,
        presets=PRESETS,
        measure=_measure,
        commands=COMMANDS,
    )


__getattr__ = lazy_attributes(__name__, _LAZY, {"MODEL": _model})


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
