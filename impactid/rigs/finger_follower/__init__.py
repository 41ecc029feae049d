"""Finger-follower valve train with a hydraulic lash adjuster (Kim, Jeon & Park 1990)."""
