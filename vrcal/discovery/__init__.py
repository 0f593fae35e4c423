"""Discovery: where the paper's model and a measurement disagree, and which effect closes the gap.

``residuals``: a model (the baseline plus effects of :mod:`vrcal.drop.effects`) fitted to a
measurement by least squares, its residuals and statistics (χ², AIC, BIC, evidence).
``ranking``: ``vrcal discover`` -- candidates fitted, tested for materiality and ranked by
evidence, round by round. ``report``: the text report and the figure.

Reads :mod:`vrcal.measurements`, simulates with :mod:`vrcal.drop`; writes nothing itself.
"""
