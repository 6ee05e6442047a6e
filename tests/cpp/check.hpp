// A minimal test harness: CHECK macros, seeded random numbers and a shared
// main() taking optional [cases] [seed] from the command line, so that CI runs
// a few hundred cases and a developer can run millions.
#pragma once

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>

namespace ibvs_test {

inline int failures = 0;
inline int checks = 0;
inline int cases = 500;
inline unsigned seed = 42;

inline void report(bool ok, const char* expr, const char* file, int line, const std::string& detail = {}) {
  ++checks;
  if (ok) return;
  ++failures;
  std::fprintf(stderr, "%s:%d: CHECK failed: %s %s\n", file, line, expr, detail.c_str());
#if defined(IBVS_LIBFUZZER)
  __builtin_trap();  // libFuzzer: a failed check is a crash, saved with its input
#endif
}

}  // namespace ibvs_test

#define CHECK(cond) ::ibvs_test::report(static_cast<bool>(cond), #cond, __FILE__, __LINE__)
#define CHECK_NEAR(a, b, tol)                                                                     \
  do {                                                                                            \
    const double ca_ = (a), cb_ = (b);                                                            \
    ::ibvs_test::report(std::abs(ca_ - cb_) <= (tol), #a " ~ " #b, __FILE__, __LINE__,            \
                        "(" + std::to_string(ca_) + " vs " + std::to_string(cb_) + ")");          \
  } while (0)
#define CHECK_THROWS(stmt)                                   \
  do {                                                       \
    bool thrown_ = false;                                    \
    try {                                                    \
      stmt;                                                  \
    } catch (const std::exception&) {                        \
      thrown_ = true;                                        \
    }                                                        \
    ::ibvs_test::report(thrown_, "throws: " #stmt, __FILE__, __LINE__); \
  } while (0)

#if !defined(IBVS_LIBFUZZER)  // libFuzzer brings its own main
// Each test file defines run_tests(); this main parses [cases] [seed] and reports.
void run_tests();

int main(int argc, char** argv) {
  if (argc > 1) ibvs_test::cases = std::atoi(argv[1]);
  if (argc > 2) ibvs_test::seed = static_cast<unsigned>(std::strtoul(argv[2], nullptr, 10));
  run_tests();
  std::printf("%d checks, %d failed (cases=%d, seed=%u)\n", ibvs_test::checks, ibvs_test::failures, ibvs_test::cases,
              ibvs_test::seed);
  return ibvs_test::failures == 0 && ibvs_test::checks > 0 ? 0 : 1;
}
#endif
