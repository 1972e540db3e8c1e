"""Scenes of the reference study: sweep tool, soil assemblies, soil bin, ringing test, direct shear box."""
