// The visual report of a prefilter (`shrm prefilter --report-html`, docs/cli.md "Visual
// report") and the index page of a batch's reports: one self-contained HTML file each. Images
// are inlined as data: URIs and plots as inline SVG; a Content-Security-Policy forbids every
// network request, script and external style, so the file opens the same offline, from a mail
// or from an artifact store. The page also carries its numbers as JSON
// (<script type="application/json" id="shrm-report-data">), which tests and tools read.
// Every front end renders the same page from the same data (the report JSON and
// PrefilterVisuals), whether the job ran embedded or on shrmd.
#ifndef SHRM_JOBS_REPORT_HTML_H_
#define SHRM_JOBS_REPORT_HTML_H_

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace shrm::jobs {

// The page: `report` is the job's JSON report (PrefilterReportJson plus what the front end adds:
// source, output, timings), `visuals` is PrefilterVisuals' JSON.
std::string RenderPrefilterReportHtml(const nlohmann::json& report, const nlohmann::json& visuals);

// One job of a batch's index page.
struct ReportIndexEntry {
  std::string name;                  // the job's name (its output file)
  std::string report_href;           // relative link to its report page ("" when it has none)
  std::string status;                // "ok", "skipped", or the error
  std::string summary;               // one line: BRDF, orders, measured error
  std::string thumbnail_png_base64;  // the SHRM spheres, small ("" when none)
};
std::string RenderReportIndexHtml(const std::string& title,
                                  const std::vector<ReportIndexEntry>& entries);

// The spheres' thumbnail of a report (base64 PNG, 3 x kThumbnailSpherePixels wide) for an
// index page, or "": from its visuals, or from a page written before (the page's icon).
std::string ReportThumbnail(const nlohmann::json& visuals);
std::string ReportThumbnailFromPage(const std::string& html);

}  // namespace shrm::jobs

#endif  // SHRM_JOBS_REPORT_HTML_H_
