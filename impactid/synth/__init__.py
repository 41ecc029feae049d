"""Synthetic recordings with known parameters (the papers' S2/S3 simulations, rig F encoders).

* :func:`synth_pivoted` - rig P, S2 (Hunt–Crossley) or S3 (restitution) with sensor models;
* :func:`synth_flat_encoders` - rig F in permanent contact, quantised encoders, unknown cam zero;
* :class:`SensorModel` - noise, ADC, accelerometer offset/drift, anti-alias decimation, encoders;
* :func:`example_recording_path` - the built-in example recording (cached);
* :func:`synth_drop`, :func:`synth_audio`, :func:`write_phyphox_xlsx`, :func:`write_wav` - bounce timings
  and bounce sound of a ball dropped on a floor, with trigger faults (from :mod:`impactid.rigs.ball.synth`).

Everything that generated a file is written to its ``/truth`` group, which impactid's estimators
never read.
"""

from impactid.rigs.ball.synth import synth_audio, synth_drop, write_phyphox_csv, write_phyphox_xlsx, write_wav
from impactid.synth.example import example_recording_path, example_recording_paths
from impactid.synth.flat import synth_flat_encoders
from impactid.synth.pivoted import SyntheticRecording, pivot_reaction, synth_pivoted
from impactid.synth.sensors import SensorModel

__all__ = ["SensorModel", "SyntheticRecording", "example_recording_path", "example_recording_paths", "pivot_reaction",
           "synth_audio", "synth_drop", "synth_flat_encoders", "synth_pivoted", "write_phyphox_csv",
           "write_phyphox_xlsx", "write_wav"]
