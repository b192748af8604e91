// The web view's page, embedded at build time (cmake/EmbedText.cmake from web/page/).
#pragma once

#include <string_view>

namespace cairn::base::web_page {
extern const std::string_view kIndexHtml;
extern const std::string_view kAppJs;
}  // namespace cairn::base::web_page
