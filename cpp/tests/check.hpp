// A minimal check framework for the C++ tests (no test-library dependency): CHECK(cond) counts
// and reports failures, CHECK_THROWS(expr, type) checks that an exception is thrown, and
// check_summary() prints the totals and returns main()'s exit status.
#pragma once

#include <cstdio>
#include <cstdlib>

namespace nightloc_test {

inline int& failures() {
    static int count = 0;
    return count;
}

inline int& checks() {
    static int count = 0;
    return count;
}

inline int check_summary() {
    std::printf("%d checks, %d failures\n", checks(), failures());
    return failures() == 0 ? EXIT_SUCCESS : EXIT_FAILURE;
}

}  // namespace nightloc_test

#define CHECK(cond)                                                                       \
    do {                                                                                  \
        ++nightloc_test::checks();                                                        \
        if (!(cond)) {                                                                    \
            ++nightloc_test::failures();                                                  \
            std::fprintf(stderr, "%s:%d: CHECK failed: %s\n", __FILE__, __LINE__, #cond); \
        }                                                                                 \
    } while (0)

#define CHECK_THROWS(expr, type)          \
    do {                                  \
        bool threw_ = false;              \
        try {                             \
            (void)(expr);                 \
        } catch (const type&) {           \
            threw_ = true;                \
        }                                 \
        CHECK(threw_ && #expr " throws"); \
    } while (0)
