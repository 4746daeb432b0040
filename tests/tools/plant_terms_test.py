#!/usr/bin/python3
"""tools/commission/plant_terms.py edits the motor file as it says: for each
term, and for all together, the edited file parses as YAML and holds exactly
the term's keys at their place under `simulation:`, with the rest of the
file unchanged; the variants none, all, a term and all-TERM name their
terms; an unknown variant is refused with exit status 2.

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
    variants = [[term] for term in module.TERMS] + [list(module.TERMS)]
    for terms in variants:
        edited = yaml.safe_load(module.motor_with(text, terms, motor_path))
        expected = yaml.safe_load(text)
        for term in terms:
            section, keys = module.TERMS[term]
            target = expected["simulation"].setdefault(section, {})
            for key in keys:
                target.update(yaml.safe_load(key))
            for key in module.DRIVE_KEYS.get(term, []):
                expected["drive"].update(yaml.safe_load(key))
        check(edited == expected, f"{'+'.join(terms)}: the edited motor file is not the original with the term's keys "
                                  f"(differs in {[k for k in expected['simulation'] if edited['simulation'].get(k) != expected['simulation'][k]]})")
        check(edited["motor"] == original["motor"] and edited["drive"] == expected["drive"],
              f"{'+'.join(terms)}: motor: changed, or drive: is not the original with the term's drive keys")
    # The budget of a plant whose terms add: its parts sum to the whole.
    base, law_excess = 1e-15, 3e-15
    increase = {term: (k + 1) * 1e-14 for k, term in enumerate(module.TERMS)}
    rows = [("none", "oracle", 0, base, 1), ("none", "spline", 0, base + law_excess, 1)]
    rows += [(term, "oracle", 0, base + increase[term], 1) for term in module.TERMS]
    all_oracle = base + sum(increase.values())
    rows += [("all", "oracle", 0, all_oracle, 1), ("all", "spline", 0, all_oracle + law_excess, 1)]
    lines = module.error_budget(rows, "spline", ["none", "all", *module.TERMS])
    check(len(lines) == len(module.TERMS) + 4 and "100.0 % (interaction of the terms: 0.0 %)" in lines[-1]
          and "the commutation" in lines[-2] and f"{law_excess:.3g}" in lines[-2],
          "an additive plant's budget: the parts (the loop, each term, the commutation) sum to the whole:\n" +
          "\n".join(lines))
    check(module.error_budget(rows, "spline", ["none", "all"]) == [], "no budget without every term's run")
    # Variants: none, all, a term, all but a term.
    terms = list(module.TERMS)
    check(module.variant_terms("none") == [] and module.variant_terms("all") == terms and
          module.variant_terms(terms[0]) == [terms[0]] and module.variant_terms("all-" + terms[0]) == terms[1:],
          f"variants: none, all, {terms[0]}, all-{terms[0]} give {module.variant_terms('none')}, "
          f"{module.variant_terms('all')}, {module.variant_terms(terms[0])}, {module.variant_terms('all-' + terms[0])}")
    result = subprocess.run([sys.executable, script, "--terms", "none,stiffness"], capture_output=True, text=True,
                            check=False)
    check(result.returncode == 2 and "unknown variant 'stiffness'" in result.stderr,
          f"an unknown variant: exit {result.returncode}, stderr '{result.stderr.strip()}'")
    result = subprocess.run([sys.executable, script, "--terms", "all-stiffness"], capture_output=True, text=True,
                            check=False)
    check(result.returncode == 2 and "unknown variant 'all-stiffness'" in result.stderr,
          f"all-TERM of an unknown term: exit {result.returncode}, stderr '{result.stderr.strip()}'")
    print(f"plant_terms_test: {len(variants)} edits of {motor_path} as expected; an unknown variant refused (exit 2)")


if __name__ == "__main__":
    main()
