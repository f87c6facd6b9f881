// index.html of `meshgauge report`: one self-contained page (pictures
// embedded as data URIs, the interactive view's scripts inline, nothing
// fetched) built from report.json.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace meshgauge::cli {

// report: the report.json object; views_png, histogram_png: the bytes of
// the two pictures; viewer_data: ViewerData (client/cli/report_viewer.h).
std::string ReportHtml(const nlohmann::json& report,
                       const std::string& views_png,
                       const std::string& histogram_png,
                       const nlohmann::json& viewer_data);

}  // namespace meshgauge::cli
