#!/usr/bin/python3
"""Commissions the embedded simulated motor with the plant's dynamics beyond a
rigid mass (docs/simulator.md, "The plant's dynamics beyond a rigid mass")
switched on one at a time, all together and none, and prints what each does
to every law's true driving-force error and tracking (docs/simulator.md,
"A realistic plant: sizes and what it does").

    tools/commission/plant_terms.py [--clm build/bin/clm] [--config config/servod.yaml]
                                    [--out out/plant-terms] [--terms none,all,flexible_mode,...]
    tools/commission/plant_terms.py --write VARIANT|shipped [--absolute-encoder] --config C --out DIR

A variant is none, all, one term, all-TERM (every term but that one:
what a term adds to the others), dynamics (the terms that shape how errors
travel: DYNAMICS) or dynamics+SOURCE (those and one of the SOURCES, the
terms that inject an error). Each variant is `clm commission
--no-plots` on a copy of the configuration and its motor file with
exactly its terms' keys (the others' removed: the shipped motors carry
every term); nothing outside --out is
written. Exit status 2 for bad usage or a configuration it cannot edit,
1 when a commissioning fails.
"""

import argparse
import json
import os
import re
import shutil
import subprocess
import sys

# The sizes of a stage like the default motor's (15 kg, 0.24 m stroke): why
# each is plausible is in docs/simulator.md. Each term: its section of the
# motor file's `simulation:` and its keys there.
TERMS = {
    "flexible_mode": ("mechanics",
                      ["flexible_mode: {frequency_Hz: 300.0, damping_ratio: 0.02, encoder_mass_fraction: 0.3}"]),
    "force_disturbance": ("mechanics", ["force_disturbance: {rms_N: 0.3, low_Hz: 1.0, high_Hz: 50.0, seed: 3}"]),
    "current_loop": ("drive", ["current_loop: {bandwidth_Hz: 1500.0, phase_resistance_ohm: 2.0, "
                               "phase_inductance_H: 0.001, voltage_limit_V: 150.0}"]),
    "setpoint_delay": ("drive", ["setpoint_delay_s: 2.0e-4"]),
    "encoder": ("sensors", ["encoder_resolution_m: 1.0e-9", "encoder_noise_m: 1.0e-9", "encoder_delay_s: 1.0e-4",
                            "encoder_scale_pitch_m: 2.0e-5", "encoder_interpolation_error_m: 5.0e-9",
                            "encoder_interpolation_second_m: 2.0e-9"]),
}

# The terms that inject an error into the loop, and those that shape how
# errors travel through it (sim::ErrorSources, whose split the report's error
# budget makes, docs/commissioning.md "The error budget").
SOURCES = ("force_disturbance", "encoder")
DYNAMICS = tuple(term for term in TERMS if term not in SOURCES)

# An incremental encoder's unknown zero (docs/servod.md, "Homing"): the
# encoder's power-up offset and its reference marks under simulation.sensors,
# and the configuration's homing: section. Not a term of the dynamics: a
# copy keeps it as the configuration has it, or (--absolute-encoder) reads
# the true position from the first cycle, as the tests of other mechanisms
# than homing want it.
INCREMENTAL_ENCODER_KEYS = ["encoder_power_up_offset_max_m", "encoder_offset_seed", "index_pitch_m",
                            "reference_switch_min_m", "reference_switch_max_m"]

# What the daemon is told of a term, as a drive's manual or a measured
# frequency response gives it: 10 % off the truth above. Each term: its
# top-level section of the motor file (motor: or drive:) and its keys there.
DESCRIPTION_KEYS = {
    "flexible_mode": ("motor", ["flexible_mode: {frequency_Hz: 270.0, damping_ratio: 0.02}"]),
    "current_loop": ("drive", ["current_loop: {bandwidth_Hz: 1350.0, phase_resistance_ohm: 2.2, "
                               "phase_inductance_H: 0.0011}"]),
    "setpoint_delay": ("drive", ["setpoint_delay_s: 1.8e-4"]),
    "encoder": ("drive", ["position_delay_s: 9.0e-5"]),
}


class UsageError(Exception):
    pass


def variant_terms(variant):
    """The terms of a variant: none, all, a term, all-TERM (all but TERM),
    dynamics (DYNAMICS) or dynamics+SOURCE (DYNAMICS and one of SOURCES)."""
    if variant == "none":
        return []
    if variant == "all":
        return list(TERMS)
    if variant in TERMS:
        return [variant]
    if variant.startswith("all-") and variant[4:] in TERMS:
        return [term for term in TERMS if term != variant[4:]]
    if variant == "dynamics":
        return list(DYNAMICS)
    if variant.startswith("dynamics+") and variant[9:] in SOURCES:
        return [term for term in TERMS if term in DYNAMICS or term == variant[9:]]
    raise UsageError(f"--terms: unknown variant '{variant}' (none, all, a term, all-TERM, dynamics or "
                     f"dynamics+SOURCE; terms: {', '.join(TERMS)}; sources: {', '.join(SOURCES)})")


def default_variants():
    """No term, each alone, all, and the dynamics without the sources."""
    return ["none", *TERMS, "all", "dynamics"]


def with_key_replaced(text, indent, key):
    """`text` with its line of `key`'s name at `indent` replaced by `key`
    (a comment on it goes too), or None when there is no such line."""
    name = key.split(":", 1)[0]
    existing = re.search(r"^" + indent + re.escape(name) + r":.*\n", text, re.MULTILINE)
    if existing is None:
        return None
    return text[:existing.start()] + indent + key + "\n" + text[existing.end():]


def motor_with(text, terms, motor_path):
    """The motor file's text with exactly `terms` on: each of their keys
    replaces the line of the same key in its section, or is added at the
    section's end, and the daemon's side of a term (DESCRIPTION_KEYS) goes
    into its top-level section; every other term's keys, both sides, are removed
    (a term's keys absent: the term is off, docs/simulator.md)."""
    for term in TERMS:
        if term not in terms:
            text = without_term(text, term)
    for term in terms:
        section, keys = TERMS[term]
        for key in keys:
            replaced = with_key_replaced(text, "    ", key)
            if replaced is not None:
                text = replaced
                continue
            header = re.search(r"^  " + section + r":\n", text, re.MULTILINE)
            if header is None and section == "drive":
                top = re.search(r"^simulation:\n", text, re.MULTILINE)
                if top is None:
                    raise UsageError(f"{motor_path}: no 'simulation:' section to add the term {term} to")
                at = section_end(text, top.end(), "  ")  # a new subsection goes last
                text = text[:at] + "  drive:\n" + text[at:]
                header_end = at + len("  drive:\n")
            elif header is None:
                raise UsageError(f"{motor_path}: no 'simulation.{section}:' section to add the term {term} to")
            else:
                header_end = header.end()
            end = section_end(text, header_end, "    ")
            text = text[:end] + "    " + key + "\n" + text[end:]
        top, described = DESCRIPTION_KEYS.get(term, ("drive", []))
        for key in described:
            replaced = with_key_replaced(text, "  ", key)
            if replaced is not None:
                text = replaced
                continue
            header = re.search(r"^" + top + r":\n", text, re.MULTILINE)
            if header is None:
                raise UsageError(f"{motor_path}: no '{top}:' section to add the term {term} to")
            end = section_end(text, header.end(), "  ")
            text = text[:end] + "  " + key + "\n" + text[end:]
    return text


def section_end(text, start, indent):
    """Where the section whose first line starts at `start` ends: after its
    last line indented by at least `indent` (a new key goes there, so the
    lines before it keep their numbers)."""
    end = start
    while end < len(text) and text.startswith(indent, end):
        newline = text.find("\n", end)
        end = len(text) if newline < 0 else newline + 1
    return end


def without_term(text, term):
    """`text` without `term`'s keys: its lines under simulation: (indented
    four spaces) and its DESCRIPTION_KEYS at the top level (two), and a
    simulation.drive: section left empty by that."""
    names = [key.split(":", 1)[0] for key in TERMS[term][1]]
    for name in names:
        text = re.sub(r"^    " + re.escape(name) + r":.*\n", "", text, flags=re.MULTILINE)
    for key in DESCRIPTION_KEYS.get(term, ("drive", []))[1]:
        text = re.sub(r"^  " + re.escape(key.split(":", 1)[0]) + r":.*\n", "", text, flags=re.MULTILINE)
    return re.sub(r"^  drive:\n(?!    )", "", text, flags=re.MULTILINE)


def with_absolute_encoder(config_text, motor_text):
    """The configuration without its homing: section and the motor file
    without INCREMENTAL_ENCODER_KEYS: an encoder that reads the true
    position from the first cycle."""
    config_text = re.sub(r"^homing:.*\n(?:(?:  .*)?\n)*", "", config_text, flags=re.MULTILINE)
    for name in INCREMENTAL_ENCODER_KEYS:
        motor_text = re.sub(r"^    " + re.escape(name) + r":.*\n", "", motor_text, flags=re.MULTILINE)
    return config_text, motor_text


def write_variant(config, out, terms, absolute_encoder=False):
    """A copy of `config`, its programs and its motor file with exactly
    `terms` in `out` (emptied first; terms None: the motor's own, as they
    are), the encoder absolute if `absolute_encoder`; the copied
    configuration's path."""
    source_dir = os.path.dirname(os.path.abspath(config))
    with open(config, encoding="utf-8") as f:
        config_text = f.read()
    match = re.search(r"^motor_file:\s*(\S+)", config_text, re.MULTILINE)
    if match is None:
        raise UsageError(f"{config}: no motor_file key")
    motor_path = os.path.join(source_dir, match.group(1))
    with open(motor_path, encoding="utf-8") as f:
        motor_text = f.read()
    if terms is not None:
        motor_text = motor_with(motor_text, terms, motor_path)
    if absolute_encoder:
        config_text, motor_text = with_absolute_encoder(config_text, motor_text)
    if os.path.exists(out):
        shutil.rmtree(out)
    os.makedirs(out)
    with open(os.path.join(out, os.path.basename(config)), "w", encoding="utf-8") as f:
        f.write(config_text)
    programs = os.path.join(source_dir, "programs")
    if os.path.isdir(programs):
        shutil.copytree(programs, os.path.join(out, "programs"))
    with open(os.path.join(out, match.group(1)), "w", encoding="utf-8") as f:
        f.write(motor_text)
    return os.path.join(out, os.path.basename(config))


def commission(clm, config, out, terms):
    """Runs clm commission on a copy of `config` with `terms`; the report's JSON."""
    copied = write_variant(config, out, terms)
    result = subprocess.run([clm, "commission", "--config", copied, "--out", os.path.join(out, "commission"),
                             "--no-plots"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, check=False)
    if result.returncode != 0:
        tail = result.stdout.strip().splitlines()[-1:] or ["(no output)"]
        raise RuntimeError(f"clm commission with {'+'.join(terms) or 'no terms'} failed: {tail[0]}")
    with open(os.path.join(out, "commission", "report.json"), encoding="utf-8") as f:
        return json.load(f)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--clm", default="build/bin/clm")
    parser.add_argument("--config", default="config/servod.yaml")
    parser.add_argument("--out", default="out/plant-terms")
    parser.add_argument("--terms", default=",".join(default_variants()),
                        help="comma-separated variants: none, all, a term (" + ", ".join(TERMS) +
                        "), all-TERM (every term but that one), dynamics (" + ", ".join(DYNAMICS) +
                        ") or dynamics+SOURCE (" + ", ".join(SOURCES) + ")")
    parser.add_argument("--write", metavar="VARIANT",
                        help="only write the configuration, its programs and its motor file with VARIANT's terms "
                        "into --out (no commissioning): e.g. none, the ideal plant the cycle's tests run on; "
                        "shipped: the motor file's terms as they are")
    parser.add_argument("--absolute-encoder", action="store_true",
                        help="with --write: an absolute encoder (no power-up offset, reference marks or homing:)")
    args = parser.parse_args()
    if args.write is not None:
        terms = None if args.write == "shipped" else variant_terms(args.write)
        print(write_variant(args.config, args.out, terms, args.absolute_encoder))
        return
    if args.absolute_encoder:
        raise UsageError("--absolute-encoder goes with --write")
    variants = args.terms.split(",")
    terms_of = {variant: variant_terms(variant) for variant in variants}
    rows = []
    for variant in variants:
        terms = terms_of[variant]
        report = commission(args.clm, args.config, os.path.join(args.out, variant), terms)
        laws = report["commutations"]
        oracle = laws.get("oracle", {}).get("tracking_mse_m2")
        for name, law in laws.items():
            if not law.get("evaluated"):
                continue
            tracking = law["tracking_mse_m2"]
            rows.append((variant, name, law["true_electromagnetic_mse"]["filtered"][0],
                         law["static_electromagnetic_mse"]["filtered"][0], tracking,
                         tracking / oracle if oracle else float("nan")))
        print(f"plant_terms: {variant} done", file=sys.stderr)
    width = max(18, *(len(variant) for variant in variants))
    print(f"{'plant':{width}} {'law':16} {'true y [N^2]':>13} {'static y [N^2]':>15} {'tracking [m^2]':>15} "
          f"{'/oracle':>8}")
    for variant, name, true_y, static_y, tracking, ratio in rows:
        print(f"{variant:{width}} {name:16} {true_y:13.3g} {static_y:15.3g} {tracking:15.3g} {ratio:8.3g}")


if __name__ == "__main__":
    try:
        main()
    except UsageError as error:
        print(f"plant_terms: {error}", file=sys.stderr)
        sys.exit(2)
    except (OSError, RuntimeError, KeyError, ValueError) as error:
        print(f"plant_terms: {error}", file=sys.stderr)
        sys.exit(1)
