"""Synthetic recordings with known parameters (the papers' S2/S3 simulations, rig F encoders).

* :func:`synth_pivoted` - rig P, S2 (Hunt–Crossley) or S3 (restitution) with sensor models;
* :func:`synth_flat_encoders` - rig F in permanent contact, quantised encoders, unknown cam zero;
* :class:`SensorModel` - noise, ADC, accelerometer offset/drift, anti-alias decimation, encoders;
* :func:`example_recording_path` - the built-in example recording (cached).

Everything that generated a file is written to its ``/truth`` group, which impactid's estimators
never read.
"""

from impactid.synth.example import example_recording_path, example_recording_paths
from impactid.synth.flat import synth_flat_encoders
from impactid.synth.pivoted import SyntheticRecording, pivot_reaction, synth_pivoted
from impactid.synth.sensors import SensorModel

__all__ = ["SensorModel", "SyntheticRecording", "example_recording_path", "example_recording_paths", "pivot_reaction",
           "synth_flat_encoders", "synth_pivoted"]
