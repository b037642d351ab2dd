#include "jobs/report.h"

#include "core/io/atomic_file.h"

namespace shrm::jobs {

nlohmann::json AnalysisJson(const ShrmAnalysis& a) {
  nlohmann::json j;
  j["epsilon"] = a.epsilon;
  j["F_L"] = a.f_light >= 0 ? nlohmann::json(a.f_light) : nlohmann::json(nullptr);
  j["F_rho"] = a.f_brdf;
  j["P_rho"] = a.p_brdf;
  j["F_B"] = a.f_b;
  j["P_B"] = a.p_b;
  j["eps_light"] = a.eps_light;
  j["eps_brdf"] = a.eps_brdf;
  j["eps_estimate"] = a.eps_estimate;
  j["eps_bound"] = a.eps_bound;
  j["brdf_tolerance_met"] = a.brdf_tolerance_met;
  j["suggested_face_size"] = a.suggested_face_size;
  j["suggested_view_size"] = a.suggested_view_size;
  j["light_total_energy"] = a.light_total;
  j["brdf_total_energy"] = a.brdf_total;
  nlohmann::json curves = nlohmann::json::array();
  for (const auto& p : a.curves) {
    curves.push_back({{"F", p.f},
                      {"light", p.light},
                      {"brdf", p.brdf},
                      {"B", p.b},
                      {"min_estimate", p.min_estimate},
                      {"bound", p.bound}});
  }
  j["curves"] = curves;
  j["curves_reference_F"] = a.reference_f;
  return j;
}

nlohmann::json TimingsJson(const std::vector<StageTiming>& timings) {
  nlohmann::json j = nlohmann::json::object();
  for (const StageTiming& t : timings) j[t.stage + "_ms"] = t.ms;
  return j;
}

absl::Status WriteJsonFile(const std::string& path, const nlohmann::json& j) {
  return WriteFileAtomically(path, j.dump(2) + "\n");
}

}  // namespace shrm::jobs
