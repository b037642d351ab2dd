#include "core/brdf/brdf_shader_params.h"

#include <cmath>
#include <memory>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "core/brdf/brdf_models.h"

namespace shrm {

absl::StatusOr<BrdfShaderParams> BrdfShaderParamsFor(const Brdf& brdf) {
  BrdfShaderParams p;
  auto& v = p.values;
  auto f = [](double x) { return static_cast<float>(x); };
  if (const auto* lambert = dynamic_cast<const LambertBrdf*>(&brdf)) {
    p.model = BrdfShaderModel::kLambert;
    v[0] = f(lambert->albedo());
  } else if (const auto* phong = dynamic_cast<const PhongBrdf*>(&brdf)) {
    p.model = BrdfShaderModel::kPhong;
    v[0] = f(phong->exponent());
  } else if (const auto* microfacet = dynamic_cast<const MicrofacetBrdf*>(&brdf)) {
    p.model = BrdfShaderModel::kMicrofacet;
    v[0] = f(microfacet->sigma());
  } else if (const auto* lafortune = dynamic_cast<const LafortuneBrdf*>(&brdf)) {
    const std::vector<LafortuneLobe>& lobes = lafortune->lobes();
    if (lobes.size() > static_cast<size_t>(kBrdfShaderLafortuneLobes)) {
      return absl::FailedPreconditionError(
          absl::StrCat("the shaders sum peak lights for Lafortune BRDFs of at most ",
                       kBrdfShaderLafortuneLobes, " lobes, not ", lobes.size()));
    }
    p.model = BrdfShaderModel::kLafortune;
    v[0] = f(lafortune->rho_d());
    v[1] = f(static_cast<double>(lobes.size()));
    for (size_t k = 0; k < lobes.size(); ++k) {
      v[4 + 4 * k] = f(lobes[k].cxy);
      v[5 + 4 * k] = f(lobes[k].cz);
      v[6 + 4 * k] = f(lobes[k].n);
      v[7 + 4 * k] = f(lobes[k].rho);
    }
  } else if (const auto* ward = dynamic_cast<const WardBrdf*>(&brdf)) {
    p.model = BrdfShaderModel::kWard;
    v[0] = f(ward->alpha_x());
    v[1] = f(ward->alpha_y());
    v[2] = f(ward->rho_s());
    v[3] = f(ward->rho_d());
  } else if (const auto* ggx = dynamic_cast<const GgxBrdf*>(&brdf)) {
    p.model = BrdfShaderModel::kGgx;
    v[0] = f(ggx->alpha());
    v[1] = f(ggx->f0());
  } else if (const auto* kajiya = dynamic_cast<const KajiyaKayBrdf*>(&brdf)) {
    p.model = BrdfShaderModel::kKajiyaKay;
    v[0] = f(kajiya->exponent());
    v[1] = f(kajiya->normalization());
  } else {
    return absl::FailedPreconditionError(absl::StrCat(
        "the shaders sum peak lights for the analytic models (lambert, phong, microfacet, "
        "lafortune, ward, ggx, kajiya-kay), not ",
        brdf.spec()));
  }
  return p;
}

absl::StatusOr<BrdfShaderParams> PeakLightShaderParams(const std::string& label,
                                                       const std::string& spec, size_t light_count,
                                                       const std::string& remedy) {
  absl::StatusOr<std::unique_ptr<Brdf>> brdf = ParseBrdfSpec(spec);
  if (!brdf.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat(label, ": its ", light_count,
                     " peak lights need the BRDF of shrm:brdf: ", brdf.status().message()));
  }
  absl::StatusOr<BrdfShaderParams> params = BrdfShaderParamsFor(**brdf);
  if (!params.ok()) {
    return absl::FailedPreconditionError(absl::StrCat(label, ": the SHRM carries ", light_count,
                                                      " peak lights, but ",
                                                      params.status().message(), ": ", remedy));
  }
  return params;
}

std::string FormatBrdfShaderParams(const BrdfShaderParams& params) {
  std::string out = absl::StrCat(static_cast<int>(params.model));
  for (float x : params.values) absl::StrAppend(&out, " ", absl::StrFormat("%.9g", x));
  return out;
}

absl::StatusOr<BrdfShaderParams> ParseBrdfShaderParams(std::string_view text) {
  const std::vector<std::string> words =
      absl::StrSplit(absl::string_view(text.data(), text.size()), ' ', absl::SkipEmpty());
  auto bad = [&](auto&&... what) {
    return absl::InvalidArgumentError(absl::StrCat("bad shrm:light_model: ", what...));
  };
  if (words.size() != 1 + kBrdfShaderValues) {
    return bad("expected a model number and ", kBrdfShaderValues, " values, got ", words.size(),
               " words");
  }
  int model = 0;
  if (!absl::SimpleAtoi(words[0], &model) || model < static_cast<int>(BrdfShaderModel::kLambert) ||
      model > static_cast<int>(BrdfShaderModel::kKajiyaKay)) {
    return bad("unknown model '", words[0], "'");
  }
  BrdfShaderParams p;
  p.model = static_cast<BrdfShaderModel>(model);
  for (int i = 0; i < kBrdfShaderValues; ++i) {
    if (!absl::SimpleAtof(words[1 + i], &p.values[i]) || !std::isfinite(p.values[i])) {
      return bad("value ", i, " '", words[1 + i], "' is not a finite number");
    }
  }
  return p;
}

}  // namespace shrm
