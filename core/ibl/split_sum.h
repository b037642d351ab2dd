// The split-sum prefiltered radiance (docs/ibl.md).
#ifndef SHRM_CORE_IBL_SPLIT_SUM_H_
#define SHRM_CORE_IBL_SPLIT_SUM_H_

namespace shrm::ibl {}  // namespace shrm::ibl

#endif  // SHRM_CORE_IBL_SPLIT_SUM_H_
