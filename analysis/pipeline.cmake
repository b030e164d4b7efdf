# analysis/pipeline: detect -> verify -> fit for a set of photos, result.json (pipeline.h) and the overlays
# (overlay.h).
find_package(OpenCV 4.6 REQUIRED COMPONENTS core imgproc imgcodecs)
add_library(curvecheck_analysis_pipeline STATIC pipeline.cc overlay.cc result_json.cc)
target_link_libraries(curvecheck_analysis_pipeline
  PUBLIC curvecheck_detect curvecheck_analysis_verify curvecheck_analysis_fit curvecheck_pattern curvecheck_core
  PRIVATE curvecheck_analysis_report opencv_core opencv_imgproc opencv_imgcodecs fmt::fmt)
target_link_libraries(curvecheck_analysis INTERFACE curvecheck_analysis_pipeline)

# analysis/analyze_run: `curvecheck analyze` once its options are parsed (analyze_run.h): the checks of its outputs,
# the analysis, and result.json, the overlays and report.html written as one set.
add_library(curvecheck_analysis_run STATIC analyze_run.cc)
target_link_libraries(curvecheck_analysis_run PUBLIC curvecheck_analysis_pipeline
                      PRIVATE curvecheck_analysis_report curvecheck_analysis_result_reader curvecheck_core fmt::fmt)
target_link_libraries(curvecheck_analysis INTERFACE curvecheck_analysis_run)
