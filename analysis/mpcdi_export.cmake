# analysis/mpcdi_export: `curvecheck export-mpcdi`, the correction of a result.json (or a monitor) as an MPCDI file
# (mpcdi_export.h). Links the MPCDI writer (mpcdi/, below analysis) and the result.json reader.
add_library(curvecheck_analysis_mpcdi STATIC ${CMAKE_CURRENT_SOURCE_DIR}/mpcdi_export.cc)
target_link_libraries(curvecheck_analysis_mpcdi PUBLIC curvecheck_core
                      PRIVATE curvecheck_analysis_result_reader curvecheck_mpcdi curvecheck_datasets fmt::fmt)
target_link_libraries(curvecheck_analysis INTERFACE curvecheck_analysis_mpcdi)
