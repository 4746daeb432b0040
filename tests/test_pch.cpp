// The translation unit of the tests' precompiled header (tests/CMakeLists.txt,
// clm_test_pch): every test binary reuses the header built here.
