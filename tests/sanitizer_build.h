#pragma once
// Whether this test binary is a sanitizer build (deploy/sanitize.sh: ASan + UBSan or TSan),
// where the instrumented code runs 3-10 times slower. Tests use it to size their work
// (docs/testing.md, "Jobs in sanitizer builds"); the one bound it relaxes, the daemon's 1 s stop
// on cancel (3 s there), is checked as written in Release.

#if defined(__has_feature)
#define FRAGSIM_TEST_HAS_FEATURE(x) __has_feature(x)
#else
#define FRAGSIM_TEST_HAS_FEATURE(x) 0
#endif

namespace fragsim::testing {

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__) || \
    FRAGSIM_TEST_HAS_FEATURE(address_sanitizer) || FRAGSIM_TEST_HAS_FEATURE(thread_sanitizer)
inline constexpr bool kSanitized = true;
#else
inline constexpr bool kSanitized = false;
#endif

}  // namespace fragsim::testing
