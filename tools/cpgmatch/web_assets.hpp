// The dashboard page and the report's style, compiled into the program from tools/cpgmatch/web/ (see
// web/embed_assets.cmake): the page and the JSON it reads are always of one release, and the program serves
// them from the build tree and from an install alike, with no data directory to find. Chart.js is not among
// them: it is Debian's (libjs-chart.js), read at run time, so that Debian's updates reach it.
#pragma once

#include <span>
#include <string_view>

namespace cpgmatch::cli::web {

struct Asset {
  std::string_view path;          // URL path, e.g. "/dashboard.js"
  std::string_view content_type;  // e.g. "text/javascript"
  std::string_view body;
};

// "/" (the page), "/dashboard.js", "/dashboard.css".
std::span<const Asset> dashboard_assets();
// The report's stylesheet (inlined into report.html).
std::string_view report_css();

}  // namespace cpgmatch::cli::web
