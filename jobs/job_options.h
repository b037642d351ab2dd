// The options each job kind declares, and which front ends carry each one: the `shrm` command
// (flags), batch manifests ("options" keys) and the wire (shrm.v1 request fields). The front-end
// tests (tests/job_front_ends_test.cc) hold every front end to this table: each option a front end
// is declared to carry must reach the job through it with its example value, and the front end
// may expose no job option the table does not declare. A new option is added here and in
// PrefilterJob (or IblJob), then each front end's test fails until it carries it.
#ifndef SHRM_JOBS_JOB_OPTIONS_H_
#define SHRM_JOBS_JOB_OPTIONS_H_

#include <span>
#include <string_view>

#include "jobs/ibl_job.h"
#include "jobs/prefilter_job.h"

namespace shrm::jobs {

enum FrontEnd : unsigned {
  kCommandLine = 1u << 0,  // `shrm prefilter --<cli>`, `shrm ibl --<cli>`
  kManifest = 1u << 1,     // `shrm batch`: "options": {"<name>": ...}
  kWire = 1u << 2,         // shrm.v1.PrefilterRequest, shrm.v1.IblRequest (proto/job_codec.h)
};

template <typename Job>
struct JobOptionOf {
  std::string_view name;  // the manifest key and the docs' name
  std::string_view help;  // the --help text
  unsigned front_ends;    // FrontEnd bits
  // A valid value other than the default, as command-line arguments ("--epsilon 0.05") and as
  // the manifest's JSON ("0.05"; "" when the manifest does not carry it), and what it sets.
  std::string_view cli_example;
  std::string_view manifest_example;
  void (*apply_example)(Job* job);
  // Why a front end does not carry it ("" when all do).
  std::string_view why_not_everywhere;
};
using JobOption = JobOptionOf<PrefilterJob>;
using IblJobOption = JobOptionOf<IblJob>;

// The prefilter job's options (PrefilterJob and its EnvironmentSpec).
std::span<const JobOption> PrefilterJobOptions();
// The option named `name` (nullptr when undeclared).
const JobOption* FindPrefilterJobOption(std::string_view name);

// The IBL job's options (IblJob and its EnvironmentSpec: the same environment options).
std::span<const IblJobOption> IblJobOptions();
const IblJobOption* FindIblJobOption(std::string_view name);

}  // namespace shrm::jobs

#endif  // SHRM_JOBS_JOB_OPTIONS_H_
