#!/usr/bin/python3
"""tools/commission/plant_terms.py edits the motor file as it says: for each
term, for all together and for none, the edited file parses as YAML and
holds exactly those terms' keys at their place under `simulation:` (the
others' removed), with the rest of the file unchanged; the variants none, all, a term, all-TERM, dynamics and
dynamics+SOURCE name their terms, every term a source or a dynamics; an
unknown variant is refused with exit status 2.

    plant_terms_test.py PLANT_TERMS_PY MOTOR_YAML
"""

import importlib.util
import subprocess
import sys

import yaml


def check(condition, what):
    if not condition:
        print(f"plant_terms_test: FAIL: {what}")
        sys.exit(1)


def main():
    script, motor_path = sys.argv[1], sys.argv[2]
    spec = importlib.util.spec_from_file_location("plant_terms", script)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    with open(motor_path, encoding="utf-8") as f:
        text = f.read()
    original = yaml.safe_load(text)
    variants = [[]] + [[term] for term in module.TERMS] + [list(module.TERMS)]
    for terms in variants:
        edited = yaml.safe_load(module.motor_with(text, terms, motor_path))
        expected = yaml.safe_load(text)
        for term, (section, keys) in module.TERMS.items():  # every term off: its keys absent
            for key in keys:
                expected["simulation"].get(section, {}).pop(key.split(":", 1)[0], None)
            top, described = module.DESCRIPTION_KEYS.get(term, ("drive", []))
            for key in described:
                expected[top].pop(key.split(":", 1)[0], None)
        if not expected["simulation"].get("drive", True):
            del expected["simulation"]["drive"]
        for term in terms:
            section, keys = module.TERMS[term]
            target = expected["simulation"].setdefault(section, {})
            for key in keys:
                target.update(yaml.safe_load(key))
            top, described = module.DESCRIPTION_KEYS.get(term, ("drive", []))
            for key in described:
                expected[top].update(yaml.safe_load(key))
        name = "+".join(terms) or "none"
        check(edited == expected, f"{name}: the edited motor file is not the original with exactly the variant's term "
                                  f"keys (differs in {[k for k in expected['simulation'] if edited['simulation'].get(k) != expected['simulation'][k]]})")
        check(edited["motor"] == expected["motor"] and edited["drive"] == expected["drive"],
              f"{name}: motor: or drive: is not the original with exactly the variant's description keys")
    # The sources and the dynamics (sim::ErrorSources are the same sources).
    check(set(module.SOURCES) | set(module.DYNAMICS) == set(module.TERMS) and
          not set(module.SOURCES) & set(module.DYNAMICS), "every term is a source or a dynamics, not both")
    # Variants: none, all, a term, all but a term, the dynamics with or without a source.
    terms = list(module.TERMS)
    source = module.SOURCES[0]
    check(module.variant_terms("dynamics") == list(module.DYNAMICS) and
          set(module.variant_terms("dynamics+" + source)) == set(module.DYNAMICS) | {source},
          f"variants: dynamics gives {module.variant_terms('dynamics')}, dynamics+{source} "
          f"{module.variant_terms('dynamics+' + source)}")
    for variant in module.default_variants():
        module.variant_terms(variant)  # every default variant is one the script knows
    check(module.variant_terms("none") == [] and module.variant_terms("all") == terms and
          module.variant_terms(terms[0]) == [terms[0]] and module.variant_terms("all-" + terms[0]) == terms[1:],
          f"variants: none, all, {terms[0]}, all-{terms[0]} give {module.variant_terms('none')}, "
          f"{module.variant_terms('all')}, {module.variant_terms(terms[0])}, {module.variant_terms('all-' + terms[0])}")
    result = subprocess.run([sys.executable, script, "--terms", "none,stiffness"], capture_output=True, text=True,
                            check=False)
    check(result.returncode == 2 and "unknown variant 'stiffness'" in result.stderr,
          f"an unknown variant: exit {result.returncode}, stderr '{result.stderr.strip()}'")
    result = subprocess.run([sys.executable, script, "--terms", f"dynamics+{module.DYNAMICS[0]}"],
                            capture_output=True, text=True, check=False)
    check(result.returncode == 2 and "unknown variant" in result.stderr,
          f"dynamics+ a term that is not a source: exit {result.returncode}, stderr '{result.stderr.strip()}'")
    result = subprocess.run([sys.executable, script, "--terms", "all-stiffness"], capture_output=True, text=True,
                            check=False)
    check(result.returncode == 2 and "unknown variant 'all-stiffness'" in result.stderr,
          f"all-TERM of an unknown term: exit {result.returncode}, stderr '{result.stderr.strip()}'")
    print(f"plant_terms_test: {len(variants)} edits of {motor_path} as expected; an unknown variant refused (exit 2)")


if __name__ == "__main__":
    main()
