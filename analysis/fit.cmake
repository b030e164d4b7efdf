# The Ceres screen fit, model selection and deviations (issue 6 items 3-5): analysis/screen_*.
find_package(OpenCV 4.6 REQUIRED COMPONENTS core calib3d)
add_library(curvecheck_analysis_fit STATIC
  ${CMAKE_CURRENT_SOURCE_DIR}/screen_model.cc
  ${CMAKE_CURRENT_SOURCE_DIR}/screen_fit_cost.cc
  ${CMAKE_CURRENT_SOURCE_DIR}/screen_fit.cc
  ${CMAKE_CURRENT_SOURCE_DIR}/screen_fit_problem.cc
  ${CMAKE_CURRENT_SOURCE_DIR}/screen_fit_misfit.cc
  ${CMAKE_CURRENT_SOURCE_DIR}/screen_fit_select.cc
  ${CMAKE_CURRENT_SOURCE_DIR}/screen_fit_surface.cc
  ${CMAKE_CURRENT_SOURCE_DIR}/screen_fit_budget.cc
  ${CMAKE_CURRENT_SOURCE_DIR}/coverage_factor.cc
  ${CMAKE_CURRENT_SOURCE_DIR}/misfit_fields.cc
  ${CMAKE_CURRENT_SOURCE_DIR}/intrinsics_covariance.cc
  ${CMAKE_CURRENT_SOURCE_DIR}/screen_fit_pixel_locking.cc
  ${CMAKE_CURRENT_SOURCE_DIR}/screen_fit_smooth_bound.cc
  ${CMAKE_CURRENT_SOURCE_DIR}/screen_fit_linearize.cc
)
# Batches of four (the two heaviest files, screen_fit_misfit.cc and screen_fit_budget.cc, fall in the second, the
# small sidecar reader, the coverage factor, the misfit's field families, the pixel-locking signature in a third, the
# smooth bound and the linearization in a fourth; one batch of eight saves more CPU but is one 90 s job at the end of a 2-core build).
curvecheck_unity(curvecheck_analysis_fit 4)
target_link_libraries(curvecheck_analysis_fit PUBLIC curvecheck_core Ceres::ceres
                      PRIVATE curvecheck_pattern opencv_core opencv_calib3d)  # pattern: feature_id.h
target_link_libraries(curvecheck_analysis INTERFACE curvecheck_analysis_fit)

# Tests draw their observations from the synthetic camera's truth (synth).
curvecheck_add_test(screen_fit_test
  SOURCES
    ${CMAKE_CURRENT_SOURCE_DIR}/screen_model_test.cc
    ${CMAKE_CURRENT_SOURCE_DIR}/screen_fit_cost_test.cc
    ${CMAKE_CURRENT_SOURCE_DIR}/screen_fit_test.cc
    ${CMAKE_CURRENT_SOURCE_DIR}/screen_fit_budget_test.cc
  LIBS curvecheck_analysis_fit curvecheck_synth curvecheck_datasets)
