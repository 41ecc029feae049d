"""Valve train II: cycloidal cam, flat-faced follower, spring surge and an EHL line contact
(Kushwaha, Rahnejat & Jin 2000). See ``docs/rigs/cycloidal.md``."""
