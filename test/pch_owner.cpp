// Owner of the tests' precompiled header (test/CMakeLists.txt): built with the same flags as a test program, so every
// test can reuse the header. It runs nothing.
int main() { return 0; }
