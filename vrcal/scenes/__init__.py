"""Scenes: several spheres bouncing on a floor and on each other (Sections 4 and 7 of [1]).

``spec``: the scene file's schema, its loader and the result types. ``multibody``: vrcal's
event-driven simulator (Eq. 6/7 restitution per contact, Eq. 5 impulses with Coulomb friction).
``ode``: the same scene in the real ODE library. ``compare``: where the two differ. ``output``:
the CSVs, the figure, the GIF and the summary that ``vrcal scene`` writes.

Builds on :mod:`vrcal.model`.

[1] "The Graphical Method for Decision of Restitution Coefficient and Its Applications".
"""
