// The translation unit that builds the tests' precompiled header (cmake/CairnTesting.cmake,
// cairn_test_pch); it has no code of its own.
