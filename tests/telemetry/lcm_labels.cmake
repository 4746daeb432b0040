# Run by ctest after the Catch2 test list of telemetry_lcm_tests is defined:
# gives each of its tests both labels, `unit` and `lcm`.
if(DEFINED telemetry_lcm_tests_TESTS)
  set_tests_properties(${telemetry_lcm_tests_TESTS} PROPERTIES LABELS "unit;lcm")
endif()
