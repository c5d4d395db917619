// Whether this build runs under AddressSanitizer, for the few tests that
// measure what the sanitizer changes (resident memory: freed memory stays
// in its quarantine) or that repeat cheap arithmetic so often that the
// sanitized run costs minutes and checks nothing the release run does not.
// Such a test asks first:
//
//   if (testing::UnderAddressSanitizer()) GTEST_SKIP() << "why";
#pragma once

namespace simplexdb::testing {

constexpr bool UnderAddressSanitizer() {
#if defined(__SANITIZE_ADDRESS__)
  return true;
#else
  return false;
#endif
}

}  // namespace simplexdb::testing
