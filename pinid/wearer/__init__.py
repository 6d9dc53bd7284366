"""The wearer in the loop: anthropometric human segments strapped to an exoskeleton.

* :mod:`pinid.wearer.anthropometry` — segment mass, length, centre of mass and radii of gyration from
  body mass, height and sex (de Leva 1996, a data file shipped with pinid);
* :mod:`pinid.wearer.attach` — a URDF of the exoskeleton with each human segment fixed to the link it
  is strapped to (``pinid wearer``).
"""
