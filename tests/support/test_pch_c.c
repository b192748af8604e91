/* Builds the C side of the tests' precompiled header (cmake/CairnTesting.cmake). */
typedef int cairn_test_pch_c_unused;
