"""The sensor chain every rig's synthetic recordings share, and the synthetic recording type.

* :class:`SensorModel` - noise, ADC, accelerometer offset/drift, anti-alias decimation, encoders;
* :class:`SyntheticRecording` - a recording and what generated it (its ``/truth`` group).

Each rig synthesises its own recordings in its folder: rig P :func:`impactid.rigs.pivoted.synth.synth_pivoted`
(and the built-in example, :mod:`impactid.rigs.pivoted.example`), rig F
:func:`impactid.rigs.flat.synth.synth_flat_encoders`, the bouncing ball :mod:`impactid.rigs.ball.synth`,
the valve trains and the drop rig their ``synth`` modules. Everything that generated a file is written
to its ``/truth`` group, which impactid's estimators never read.
"""

from impactid.synth.recording import SyntheticRecording
from impactid.synth.sensors import SensorModel

__all__ = ["SensorModel", "SyntheticRecording"]
