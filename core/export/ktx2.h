// KTX 2.0 container writer (Khronos KTX File Format Specification 2.0). See docs/ktx2.md.
#ifndef SHRM_CORE_EXPORT_KTX2_H_
#define SHRM_CORE_EXPORT_KTX2_H_

namespace shrm::ktx2 {}  // namespace shrm::ktx2

#endif  // SHRM_CORE_EXPORT_KTX2_H_
