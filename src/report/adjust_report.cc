// report.html of `mmba adjust` (adjust_report.h): the page from its sections, in reading order.
#include "mmba/report/adjust_report.h"

#include <sstream>
#include <string>

#include "report/html_internal.h"

namespace mmba::report {

using internal::Describe;
using internal::Esc;
using internal::Fail;
using internal::OptString;
using internal::ReqString;

std::string RenderAdjustReportHtml(const nlohmann::json& report) {
  if (!report.is_object()) Fail("(root)", Describe(report), "an object");
  const std::string schema = ReqString(report, "schema", "");
  if (schema != kAdjustReportSchema) {
    Fail("schema", "\"" + schema + "\"", "\"" + std::string(kAdjustReportSchema) + "\"");
  }
  const std::string project = ReqString(report, "project", "");
  const std::string status = ReqString(report, "status", "");
  if (status != "converged" && status != "failed" && status != "no_convergence") {
    Fail("status", "\"" + status + "\"", "\"converged\", \"failed\" or \"no_convergence\"");
  }
  const internal::PageContext context{OptString(report, "project_dir", "").value_or("")};
  const nlohmann::json* groups = internal::OptArray(report, "groups", "");
  if (groups == nullptr) Fail("groups", "nothing (missing)", "an array (may be empty)");

  std::ostringstream html;
  html << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
       << "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
       << "<title>" << Esc(project) << " &middot; adjustment report</title>\n<style>" << internal::kCss
       << "</style>\n</head>\n<body>\n";
  internal::RenderHeader(report, project, status, context, html);
  internal::RenderSummary(report, status, context, html);
  internal::RenderWarnings(report, context, html);
  internal::RenderGroups(*groups, html);
  internal::RenderControlPoints(report, html);
  internal::RenderAccuracy(report, html);
  internal::RenderAdjustedPoints(report, html);
  internal::RenderRelativePrecision(report, html);
  internal::RenderObservations(report, context, html);
  internal::RenderBlunders(report, html);
  internal::RenderPhotoImages(report, context, html);
  internal::RenderPoseCorrections(report, html);
  internal::RenderMiRegistrations(report, html);
  internal::RenderCalibrations(report, html);
  internal::RenderDenseClouds(report, html);
  internal::RenderCrs(report, html);
  internal::RenderSettings(report, context, html);
  internal::RenderFiles(report, context, html);
  html << "<footer>mmba adjust &middot; report schema " << kAdjustReportSchema;
  if (auto t = OptString(report, "generated_utc", "")) html << " &middot; " << Esc(*t) << " UTC";
  html << "</footer>\n</body>\n</html>\n";
  return html.str();
}

}  // namespace mmba::report
