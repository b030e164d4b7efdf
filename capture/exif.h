// A small EXIF reader: the few tags a capture manifest records, from a JPEG's APP1 segment (or a bare TIFF
// header). Not a general EXIF library: no maker notes, no thumbnails, no XMP.
#pragma once

#include <nlohmann/json.hpp>
#include <string_view>

namespace curvecheck {

// Returns an object with those of these keys that the file carries: "make", "model", "date_time" (0x0132),
// "date_time_original" (0x9003, "YYYY:MM:DD HH:MM:SS", camera local time), "exposure_time_s", "f_number",
// "iso", "focal_length_mm" (0x920A), "focal_length_35mm" (0xA405, the 35 mm film equivalent). Returns an empty
// object for files without EXIF (PNG) or with malformed EXIF; never throws.
nlohmann::json ReadExif(std::string_view file_bytes);

}  // namespace curvecheck
