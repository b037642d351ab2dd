// The small prefilter request the service tests send: one blob, a glossy Phong lobe, explicit
// low orders (F = 8, P = 2), a small cube. Cheap on a loaded 2-core machine; the tests that use it
// check the service's behaviour, not the SHRM's values.
#ifndef SHRM_TESTS_SMALL_JOB_H_
#define SHRM_TESTS_SMALL_JOB_H_

#include <string>

#include "shrm/v1/shrm.pb.h"

namespace shrm::testing {

inline constexpr int kSmallJobF = 8;
inline constexpr int kSmallJobP = 2;
inline constexpr int kSmallJobFaceSize = 16;

inline v1::PrefilterRequest SmallPrefilterRequest(const std::string& sha256,
                                                  int face_size = kSmallJobFaceSize) {
  v1::PrefilterRequest req;
  req.mutable_environment()->add_sha256(sha256);
  req.set_brdf("phong:s=32");
  req.mutable_orders()->set_f(kSmallJobF);
  req.mutable_orders()->set_p(kSmallJobP);
  req.set_face_size(face_size);
  req.set_verify(0);  // the job's own check (absent: 64 pairs) is not what these tests check
  return req;
}

}  // namespace shrm::testing

#endif  // SHRM_TESTS_SMALL_JOB_H_
