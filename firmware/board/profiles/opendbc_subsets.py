#!/usr/bin/env python3
"""Writes the car profiles' DBCs as subsets of opendbc's (PyPI `opendbc`, MIT): for each profile,
the messages its map reads, copied unchanged (their BO_ and SG_ lines) from the opendbc DBC
named below, generated DBCs (Honda, GM, Subaru, Nissan, Chrysler) through opendbc's own
generator. tests/tests/profiles.rs decodes every mapped signal on random frames with our decoder
on the subset and with cantools on opendbc's full DBC, and requires the same values.

Run from this folder with opendbc installed: python3 opendbc_subsets.py
"""
import os
import re
import sys

# profile -> (opendbc DBC name, the messages the map reads)
PROFILES = {
    "honda_civic_2016": ("honda_civic_touring_2016_can_generated", ["WHEEL_SPEEDS", "STEERING_SENSORS"]),
    "gm_global_a": ("gm_global_a_powertrain_generated", ["EBCMWheelSpdRear", "PSCMSteeringAngle"]),
    "ford_cgea": ("ford_lincoln_base_pt", ["BrakeSysFeatures", "SteeringPinion_Data", "Yaw_Data_FD1"]),
    "vw_mqb": ("vw_mqb", ["ESP_19", "LWI_01", "ESP_02", "Motor_20"]),
    "subaru_global": ("subaru_global_2017_generated", ["Wheel_Speeds", "Steering_Torque"]),
    "nissan_x_trail_2017": ("nissan_x_trail_2017_generated", ["WHEEL_SPEEDS_REAR", "STEER_ANGLE_SENSOR"]),
    "mazda_2017": ("mazda_2017", ["WHEEL_SPEEDS", "STEER", "ENGINE_DATA"]),
    "chrysler_pacifica_2017": ("chrysler_pacifica_2017_hybrid_generated", ["SPEED_1", "STEERING"]),
    "tesla_model3": ("tesla_model3_party", ["ESP_wheelSpeeds", "EPAS3S_sysStatus", "DI_systemStatus"]),
}


def opendbc_text(name):
    import opendbc
    base = os.path.join(os.path.dirname(opendbc.__file__), "dbc")
    path = os.path.join(base, name + ".dbc")
    if os.path.isfile(path):
        return open(path, encoding="utf-8").read()
    from opendbc.dbc.generator.generator import generate_all
    return generate_all()[name]


def messages(text):
    """{name: [its BO_ line and SG_ lines]} of a DBC's text."""
    out, cur = {}, None
    for line in text.splitlines():
        m = re.match(r"^BO_ \d+ (\w+):", line)
        if m:
            cur = m.group(1)
            out[cur] = [line]
        elif cur and line.startswith(" SG_ "):
            out[cur].append(line)
        else:
            cur = None
    return out


def subset(profile):
    src, names = PROFILES[profile]
    msgs = messages(opendbc_text(src))
    from importlib.metadata import version
    head = [
        'VERSION ""',
        "",
        f'CM_ "{profile}: a subset of opendbc {version("opendbc")} {src}.dbc (MIT, commaai/opendbc), written by opendbc_subsets.py: the messages {", ".join(names)}, unchanged.";',
        "",
        "NS_ :",
        "\tCM_",
        "",
        "BS_:",
        "",
        "BU_: XXX",
        "",
    ]
    body = []
    for n in names:
        if n not in msgs:
            sys.exit(f"{src}: no message {n}")
        body += msgs[n] + [""]
    return "\n".join(head + body)


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    for p in sys.argv[1:] or PROFILES:
        with open(os.path.join(here, p + ".dbc"), "w", encoding="utf-8") as f:
            f.write(subset(p))
        print(f"wrote {p}.dbc")


if __name__ == "__main__":
    main()
