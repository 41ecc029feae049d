"""Synthetic recordings of the rigs (the papers' S2/S3 simulations as sensor data).

Generation of recordings is issue 3 (not yet implemented); the simulator it builds on is
:mod:`impactid.simulate`.
"""
