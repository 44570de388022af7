"""The plausible ranges of physical inputs in a case file, each with why: a value outside is
more likely a slip (a unit, a field) than a track."""

from __future__ import annotations

# [m/s] Most of Europe allows no level crossing on a line faster than 160 km/h (Germany's
# EBO section 11, for one); Britain has some on 125 mph (201 km/h) lines. 250 km/h leaves a
# margin above all of them and catches a speed in km/h written as m/s (140 -> 504 km/h).
MAX_SPEED = 250 / 3.6
SPEED_WHY = "no level crossing's line speed is higher"
SPEED = dict(unit="m/s", shown="km/h", gt=0, le=MAX_SPEED, why=SPEED_WHY)
MASS_WHY = "a mass per wheel is some 100 kg to 15 t"
PAD_WHY = "railpads are 20-2000 MN/m"
SEAT_WHY = "ballast support per rail seat is some 10-200 MN/m"
RATIO_WHY = ("a pad is no softer under the wheel than bought; a ratio above 10 is more likely "
              "a stiffness written in this field")
