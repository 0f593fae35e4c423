"""The paper's model: its equations, the association standards it starts from, and Table 2.

``restitution``: one pure, vectorised function per equation of [1] (Eqs. 6-10), SI units.
``standards``: the ball standards (``vrcal/standards.yaml``), validated on load, and ε from
their drop tests (Eq. 9). ``body``: one description of a body (a standard ball, or any mass and
diameter) for every command. ``table2``: Table 2 of [1] regenerated, and the paper's own
Table 2 checked. The inverse of Eqs. 7/10 (families of virtual bodies) is :mod:`vrcal.inverse`.

Nothing here reads measurements, simulates or fits: every other subpackage builds on this one.

[1] "The Graphical Method for Decision of Restitution Coefficient and Its Applications".
"""
