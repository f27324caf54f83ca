#pragma once
// Base64 (RFC 4648, padded): how an SVG or a web page embeds a raster image in a data URI, so that
// a picture or a replay page is one self-contained file.
#include <string>
#include <string_view>

namespace slamkit {

std::string base64(std::string_view bytes);

}  // namespace slamkit
