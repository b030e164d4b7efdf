# analysis/verify: is the photo a planar perspective image of the pattern? (verify.h)
add_library(curvecheck_analysis_verify STATIC verify.cc error_field.cc)
curvecheck_unity(curvecheck_analysis_verify 2)
target_link_libraries(curvecheck_analysis_verify PUBLIC curvecheck_pattern curvecheck_core PRIVATE Ceres::ceres fmt::fmt)
target_link_libraries(curvecheck_analysis INTERFACE curvecheck_analysis_verify)
curvecheck_add_test(verify_test SOURCES verify_test.cc error_field_test.cc
                    LIBS curvecheck_analysis_verify curvecheck_synth curvecheck_datasets curvecheck_core)
