# The HTML report (issue 7 item 1, analysis/report.h) and the result.json reader it and `curvecheck report` use
# (analysis/result_reader.h; fuzzed by fuzz/fuzz_result_json.cc). Charts through core/gnuplot.h (gnuplot-nox).
add_library(curvecheck_analysis_result_reader STATIC ${CMAKE_CURRENT_SOURCE_DIR}/result_reader.cc)
target_link_libraries(curvecheck_analysis_result_reader PUBLIC curvecheck_core nlohmann_json::nlohmann_json
                      PRIVATE fmt::fmt)
add_library(curvecheck_analysis_report STATIC ${CMAKE_CURRENT_SOURCE_DIR}/report.cc
            ${CMAKE_CURRENT_SOURCE_DIR}/report_charts.cc ${CMAKE_CURRENT_SOURCE_DIR}/report_format.cc)
target_link_libraries(curvecheck_analysis_report PUBLIC curvecheck_analysis_result_reader curvecheck_core
                      PRIVATE fmt::fmt opencv_imgcodecs)
target_compile_definitions(curvecheck_analysis_report PRIVATE CURVECHECK_VERSION="${PROJECT_VERSION}")
target_link_libraries(curvecheck_analysis INTERFACE curvecheck_analysis_report)

# The tests read real result.json files from the fuzz corpus (fuzz/corpus/fuzz_result_json/, made by
# `curvecheck analyze` and trimmed) and draw charts with gnuplot.
curvecheck_add_test(report_test
  SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/result_reader_test.cc ${CMAKE_CURRENT_SOURCE_DIR}/report_test.cc
  LIBS curvecheck_analysis_report curvecheck_core opencv_imgproc opencv_imgcodecs)
