"""Write the example measurement files of this folder from drag-free bounce physics (run once).

A ball dropped from rest from H = 1.0 m (bottom of the ball) onto a rigid floor with a
constant restitution epsilon = 0.85 and no air drag:

* impact speed v_0 = sqrt(2 g H) (Eq. (8) of [1], ``vrcal.model.restitution.impact_speed_m_per_s``),
  first impact at sqrt(2 H / g), flight times between impacts dt_i = 2 epsilon^(i+1) v_0 / g;
* apex heights h_i = epsilon^(2 i) H (Eq. (9) of [1] inverted).

The files imitate what real tools write (see "Reading real measurements" in README.md): a phyphox-style
acoustic export (semicolons, decimal comma, scientific notation, quoted header), the
same with an echo, the same with a missed impact near the end, a Tracker data export (track name,
tab-separated t x y, ball centre, a still hold before release, 1 mm tracking noise), and
an apex table; and a classroom table of drop and rebound heights of a table-tennis ball (five
heights, three trials each, read to 1 mm, air drag C_d 0.47 planted with vrcal's own simulator,
:func:`vrcal.drop.synthetic.drop_table_case`). Run:  python examples/data/make_examples.py
"""

from pathlib import Path

import numpy as np

from vrcal.model.restitution import STANDARD_GRAVITY_M_PER_S2 as G
from vrcal.model.restitution import impact_speed_m_per_s

HERE = Path(__file__).resolve().parent
H_M, EPS, N_IMPACTS = 1.0, 0.85, 12


def impact_times_s(release_s=0.0):
    v0 = impact_speed_m_per_s(H_M)
    flights = 2.0 * EPS ** np.arange(1, N_IMPACTS) * v0 / G
    return release_s + np.sqrt(2.0 * H_M / G) + np.concatenate([[0.0], np.cumsum(flights)])


def bottom_height_m(t_s, release_s):
    """Height of the ball's bottom at times t (held at H before release)."""
    v0 = impact_speed_m_per_s(H_M)
    impacts = impact_times_s(release_s)
    y = np.full(t_s.shape, H_M)
    falling = (t_s >= release_s) & (t_s < impacts[0])
    y[falling] = H_M - 0.5 * G * (t_s[falling] - release_s) ** 2
    for i in range(N_IMPACTS - 1):
        inside = (t_s >= impacts[i]) & (t_s < impacts[i + 1])
        v_up = EPS ** (i + 1) * v0
        tau = t_s[inside] - impacts[i]
        y[inside] = v_up * tau - 0.5 * G * tau ** 2
    return y


def phyphox_number(x):
    """phyphox-like scientific notation with a decimal comma."""
    return f"{x:.9E}".replace(".", ",")


def write(name, text):
    (HERE / name).write_text(text, encoding="utf-8")
    print("wrote", HERE / name)


def main():
    rng = np.random.default_rng(2026)
    t = impact_times_s(release_s=0.4127) + rng.normal(0.0, 2e-4, N_IMPACTS)  # 0.2 ms detection jitter
    rows = [f"{i + 1};{phyphox_number(ti)}" for i, ti in enumerate(t)]
    write("phyphox-impacts.csv", '"Event";"Event time (s)"\n' + "\n".join(rows) + "\n")

    # the same run with an echo 12 ms after impact 8, and the same run with impact 9 missed (a quiet bounce)
    t_echo = np.sort(np.concatenate([t, [t[8] + 0.012]]))
    rows = [f"{i + 1};{phyphox_number(ti)}" for i, ti in enumerate(t_echo)]
    write("phyphox-impacts-echo.csv", '"Event";"Event time (s)"\n' + "\n".join(rows) + "\n")
    t_missed = np.delete(t, 9)
    rows = [f"{i + 1};{phyphox_number(ti)}" for i, ti in enumerate(t_missed)]
    write("phyphox-impacts-missed.csv", '"Event";"Event time (s)"\n' + "\n".join(rows) + "\n")

    fps, radius_m = 60.0, 0.0335  # a tennis-ball-sized ball, centre tracked
    frames = np.arange(int(2.6 * fps))
    t_video = frames / fps
    y_centre = bottom_height_m(t_video, release_s=0.3) + radius_m + rng.normal(0.0, 1e-3, frames.size)
    x_centre = 0.05 + 0.004 * t_video + rng.normal(0.0, 1e-3, frames.size)
    lines = ["mass_A", "t\tx\ty"] + [f"{a:.9E}\t{b:.9E}\t{c:.9E}" for a, b, c in zip(t_video, x_centre, y_centre)]
    write("tracker-export.txt", "\n".join(lines) + "\n")

    bounce = np.arange(6)
    h = H_M * EPS ** (2 * bounce)
    write("apexes.csv", "bounce,h\n" + "\n".join(f"{b},{x:.4f}" for b, x in zip(bounce, h)) + "\n")

    from vrcal.discovery.residuals import observed_values
    from vrcal.drop.simulate import simulate_drops
    from vrcal.model.body import BallProperties
    from vrcal.model.standards import get_ball

    table_tennis = BallProperties.from_ball(get_ball("table_tennis"))
    heights = np.repeat([0.30, 0.70, 1.10, 1.50, 2.00], 3)
    drops = simulate_drops(heights, 0.90, 1, table_tennis, effects={"air_drag": {"drag_coefficient": 0.47}})
    noisy = drops.apex_heights_m + np.random.default_rng(9).normal(0.0, 0.001, drops.apex_heights_m.shape)
    rows = [f"{i % 3 + 1},{100 * H:.1f},{100 * hr:.1f}" for i, (H, hr) in enumerate(zip(heights, noisy[:, 1]))]
    write("drop-table.csv", "trial,H (cm),h (cm)\n" + "\n".join(rows) + "\n")
    # the same trials with each rebound read at the top of the ball (one diameter, 4.0 cm, higher)
    D_cm = 100 * float(table_tennis.diameter_m)
    rows = [f"{i % 3 + 1},{100 * H:.1f},{100 * hr + D_cm:.1f}" for i, (H, hr) in enumerate(zip(heights, noisy[:, 1]))]
    write("drop-table-top.csv", "trial,H (cm),h (cm)\n" + "\n".join(rows) + "\n")
    assert observed_values  # (imported to keep one source of the physics)


if __name__ == "__main__":
    main()
