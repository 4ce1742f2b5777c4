// Nothing: the target that compiles the test files' precompiled header (tests/CMakeLists.txt).
