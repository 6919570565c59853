"""Config texts the tests share (one copy, not one per test file)."""

#: a slotting cut with one mode per direction (fn_x 903 Hz, k_x 12.53 N/µm, ζ_x 0.03; fn_y 1050 Hz, 15 N/µm, 0.04)
TWO_MODE_TOML = """name = "t"
[cutting]
teeth = 2
kt = "556.31 MPa"
kr = 0.404
entry = "0 deg"
exit = "180 deg"
[[structure.x]]
fn = "903 Hz"
k = "12.53 N/um"
zeta = 0.03
[[structure.y]]
fn = "1050 Hz"
k = "15 N/um"
zeta = 0.04
"""
