# analysis/plan: the capture plan (issue 20 part 1): the radius sigma and verification capability a camera can
# reach, predicted with the fit's and the verification's own machinery on simulated detections (plan.h).
add_library(curvecheck_analysis_plan STATIC plan.cc plan_run.cc)
target_link_libraries(curvecheck_analysis_plan PUBLIC curvecheck_analysis_fit curvecheck_analysis_verify
                      curvecheck_pattern curvecheck_core PRIVATE curvecheck_datasets fmt::fmt)
target_link_libraries(curvecheck_analysis INTERFACE curvecheck_analysis_plan)
curvecheck_add_test(plan_test SOURCES plan_test.cc
                    LIBS curvecheck_analysis_plan curvecheck_synth curvecheck_datasets curvecheck_core)
