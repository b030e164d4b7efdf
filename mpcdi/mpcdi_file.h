// VESA MPCDI v2.0 files, profile "2d" (Multiple Projection Common Data Interchange), as `curvecheck export-mpcdi`
// writes them, and a reader for them (tests and anyone who wants to check a file). An .mpcdi file is a ZIP archive
// (written and read with Debian's minizip) holding
//   mpcdi.xml    <MPCDI profile="2d" geometry="1" color="1" version="2.0" date="...">
//                  <display><buffer id xResolution yResolution>
//                    <region id x="0" y="0" xSize="1" ySize="1" xResolution yResolution/></buffer></display>
//                  <files><fileset region="...">
//                    <geometryWarpFile> path, interpolation (linear), componentDepth (3), bitDepth (32),
//                                       xSize, ySize (the grid's samples) </geometryWarpFile>
//                    <alphaMap> path, componentDepth (1), bitDepth (8), gammaEmbedded (1.0) </alphaMap>
//                  </fileset></files></MPCDI>
//   warp.pfm     the geometry warp (mpcdi/warp_grid.h): a colour PFM ("PF"), xSize x ySize samples, scale -1.0
//                (little-endian float32), rows stored BOTTOM TO TOP as netpbm stores them (the first row in the
//                file is the bottom row of the display), R = u, G = v (v = 0 at the bottom of the source image),
//                B = 0.
//   alpha.png    8-bit grey, display resolution: 255 where the warp reads inside the source image, 0 where it
//                reads outside it (nothing to show there).
// One buffer of the display's resolution holds one region that covers it (the whole display, x = y = 0,
// xSize = ySize = 1 in normalized buffer coordinates); readers disagree on conventions, so README "MPCDI export"
// states ours.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "mpcdi/warp_grid.h"

namespace curvecheck {

// The PFM bytes of a grid (conventions above). Checks the grid (WarpGrid::Check).
std::string EncodeWarpPfm(const WarpGrid& grid);
// A grid from PFM bytes: "PF", cols rows, a scale whose sign gives the byte order (negative: little-endian), then
// the samples bottom row first; B is ignored. `source` names the data in errors; the display size is not in the
// PFM and is given. Throws Error for a header that is not a colour PFM, sizes below 2 or above 8192, a byte count
// that does not match, or a sample that is not finite.
WarpGrid DecodeWarpPfm(std::string_view bytes, const std::string& source, int display_width_px, int display_height_px);

// The alpha map of a grid (conventions above), display resolution, rows top to bottom.
std::vector<uint8_t> AlphaFromWarp(const WarpGrid& grid);

struct MpcdiWriteOptions {
  std::string comment;  // written as an XML comment at the top of mpcdi.xml (what produced the file)
  std::string date;     // the MPCDI "date" attribute, "YYYY-MM-DD HH:MM:SS"; empty: now (UTC)
};

// The mpcdi.xml of a grid (layout above).
std::string MpcdiXml(const WarpGrid& grid, const MpcdiWriteOptions& options);

// Writes the .mpcdi archive atomically (a temporary beside `path`, renamed over it): nothing is left on failure.
// Throws Error naming the file if it cannot be written.
void WriteMpcdi(const std::filesystem::path& path, const WarpGrid& grid, const MpcdiWriteOptions& options);

struct MpcdiContents {
  std::string xml;  // mpcdi.xml as stored
  std::string profile, version;
  std::string buffer_id, region_id;
  int buffer_width_px = 0, buffer_height_px = 0;  // the buffer's xResolution, yResolution
  std::string warp_path, interpolation;           // geometryWarpFile's path and interpolation
  int component_depth = 0, bit_depth = 0;         // of the geometry warp
  WarpGrid warp;                                  // decoded; display size = the region's resolution
  std::string alpha_path;                         // empty when the file has no alpha map
  int alpha_width_px = 0, alpha_height_px = 0;
  std::vector<uint8_t> alpha;  // rows top to bottom
};

// Reads an .mpcdi archive: unzips mpcdi.xml, finds the display, buffer, region and the fileset of that region,
// and decodes the geometry warp (and the alpha map, if any) it names. Throws Error naming the file (and the
// element or member) if it is not a ZIP, lacks mpcdi.xml or an element the 2d profile needs, names a member the
// archive lacks, or the PFM disagrees with xSize/ySize.
MpcdiContents ReadMpcdi(const std::filesystem::path& path);

}  // namespace curvecheck
