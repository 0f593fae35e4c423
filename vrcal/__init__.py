"""vrcal: calibrate the coefficient of restitution with the virtual-body method.

Reference
---------
[1] "The Graphical Method for Decision of Restitution Coefficient and Its
    Applications" (virtual-body restitution), equations (6), (7), (9), (10).
"""

__version__ = "0.1.0"
