// index.html of `meshgauge report`: one self-contained page (pictures
// embedded as data URIs, no script, no network) built from report.json.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace meshgauge::cli {

// report: the report.json object; views_png, histogram_png: the bytes of
// the two pictures.
std::string ReportHtml(const nlohmann::json& report,
                       const std::string& views_png,
                       const std::string& histogram_png);

}  // namespace meshgauge::cli
