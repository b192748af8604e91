// Linked into every test labelled `single-threaded` (release and cross builds): the label
// claims the code under test starts no thread, which is why the TSan pass does not build
// or run these tests. This definition takes the place of the C library's, so a test that
// starts a thread after all (std::thread included) exits at once, naming the broken claim,
// instead of silently losing its TSan coverage.
#include <pthread.h>

#include <unistd.h>

#include <cstdio>

extern "C" int pthread_create(pthread_t*, const pthread_attr_t*, void* (*)(void*), void*) {
  std::fprintf(stderr,
               "this test is labelled single-threaded (so TSan skips it) but started a thread: "
               "remove the label in tests/CMakeLists.txt\n");
  std::fflush(stderr);
  _exit(70);  // not abort(): CTest fails a killed test whatever it printed (the guard's own test)
}
