// libFuzzer target: the result.json reader (analysis/result_reader.h ParseResultJson, which `curvecheck report`
// uses), then the report page built from what it accepted (analysis/report.h ReportHtml, charts off: no gnuplot
// processes). The second half checks the reader's promise to the page: a document it accepts never makes the page
// builder fail with anything but Error (a json type_error there means the reader let through a key of the wrong
// type). Seeds: fuzz/corpus/fuzz_result_json: result.json files written by `curvecheck analyze` (every 12th feature
// kept to stay small), and edited-ill-conditioned.json, one of them edited into the shape of an ill-conditioned fit
// (null radius, condition notes, fit.warnings, a small deviation map).
#include <cstddef>
#include <cstdint>

#include "analysis/report.h"
#include "analysis/result_reader.h"
#include "fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace curvecheck;
  const std::string text = fuzz::Text(data, size);
  nlohmann::json doc;
  if (!fuzz::ParsesOrThrowsError([&] { doc = ParseResultJson(text, "fuzz.json"); })) return 0;
  ReportAssets assets;
  assets.source = "fuzz.json";
  assets.overlay_missing["photo-exact.png"] = "fuzzing";
  ReportOptions options;
  options.charts = false;
  fuzz::ParsesOrThrowsError([&] { ReportHtml(doc, assets, options); });
  return 0;
}
