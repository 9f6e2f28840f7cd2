// The program that builds the test suite's precompiled header (tests/CMakeLists.txt); it
// does nothing.
int main() { return 0; }
