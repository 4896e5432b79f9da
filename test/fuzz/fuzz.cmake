# Fuzz harnesses (test/fuzz/README.md), included from CMakeLists.txt when testing is enabled: one
# LLVMFuzzerTestOneInput per test/fuzz/fuzz_<name>.cpp, built as test_fuzz_<name> (a test
# program, not installed) and linked either
#  - with the seeded driver test/fuzz/fuzz_driver.cpp (gcc, the default): `catkin_make tests`
#    builds them, ctest replays each one's regressions and seed corpus (fuzz-replay_<name>), and
#    scripts/test --sanitize runs them for 10^4 mutated inputs each under ASan + UBSan; or
#  - with libFuzzer (-DDRILL_PIPE_POSE_LIBFUZZER=ON, clang: scripts/fuzz --libfuzzer), no ctest.
set(DPP_FUZZ_HARNESSES sensor_frame sensor_frame_cutout rig_yaml scene_yaml estimator_yaml
  pipe_catalog_yaml yolo_decoding)
# What each harness tests, i.e. links.
set(DPP_FUZZ_LIBS_sensor_frame ${PROJECT_NAME}_ros)
set(DPP_FUZZ_LIBS_sensor_frame_cutout ${PROJECT_NAME}_ros)
set(DPP_FUZZ_LIBS_rig_yaml ${PROJECT_NAME}_core)
set(DPP_FUZZ_LIBS_scene_yaml ${PROJECT_NAME}_sim)
set(DPP_FUZZ_LIBS_estimator_yaml ${PROJECT_NAME}_core)
set(DPP_FUZZ_LIBS_pipe_catalog_yaml ${PROJECT_NAME}_core)
set(DPP_FUZZ_LIBS_yolo_decoding ${PROJECT_NAME}_detector)

foreach(h ${DPP_FUZZ_HARNESSES})
  if(DRILL_PIPE_POSE_LIBFUZZER)
    add_executable(test_fuzz_${h} EXCLUDE_FROM_ALL test/fuzz/fuzz_${h}.cpp)
    target_link_libraries(test_fuzz_${h} -fsanitize=fuzzer)
  else()
    add_executable(test_fuzz_${h} EXCLUDE_FROM_ALL test/fuzz/fuzz_driver.cpp
      test/fuzz/fuzz_${h}.cpp)
    target_link_libraries(test_fuzz_${h} ${CMAKE_DL_LIBS})  # dlopen: the sanitizers' death callbacks
  endif()
  target_link_libraries(test_fuzz_${h} ${DPP_FUZZ_LIBS_${h}})
  target_compile_definitions(test_fuzz_${h} PRIVATE DPP_FUZZ_NAME="${h}"
    DPP_FUZZ_DIR="${PROJECT_SOURCE_DIR}/test/fuzz"
    DRILL_PIPE_POSE_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
  add_dependencies(test_fuzz_${h} ${PROJECT_NAME}_generate_messages_cpp)
  add_dependencies(tests test_fuzz_${h})
  if(NOT DRILL_PIPE_POSE_LIBFUZZER)
    # The regressions and the seed corpus replayed (no mutation): every crash found stays fixed.
    catkin_run_tests_target(fuzz replay_${h} fuzz-replay_${h}.xml
      COMMAND "${CATKIN_DEVEL_PREFIX}/${CATKIN_PACKAGE_BIN_DESTINATION}/test_fuzz_${h} --runs 0 --quiet --artifacts ${PROJECT_BINARY_DIR}/fuzz_artifacts --xml ${CATKIN_TEST_RESULTS_DIR}/${PROJECT_NAME}/fuzz-replay_${h}.xml"
      DEPENDENCIES test_fuzz_${h})
  endif()
endforeach()

if(NOT DRILL_PIPE_POSE_LIBFUZZER)
  # Writes the generated seed inputs (simulated SensorFrames, an estimator YAML with every key,
  # YOLO outputs) into test/fuzz/corpus/: `catkin_make test_fuzz_make_seeds`, then run it (README).
  add_executable(test_fuzz_make_seeds EXCLUDE_FROM_ALL test/fuzz/make_seeds.cpp)
  target_link_libraries(test_fuzz_make_seeds ${PROJECT_NAME}_sim_ros)
  target_compile_definitions(test_fuzz_make_seeds PRIVATE
    DRILL_PIPE_POSE_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
endif()

# ---- the sanitizer build (scripts/test --sanitize: -DDRILL_PIPE_POSE_SANITIZE=ON) ---------------
# Under ASan + UBSan the tests run 5-10 times slower (test_golden_cycles: 84 s in Release, ~670 s
# sanitized on one core): every test's time limit becomes an hour there.
if(DRILL_PIPE_POSE_SANITIZE)
  get_directory_property(dpp_all_tests TESTS)
  if(dpp_all_tests)
    set_tests_properties(${dpp_all_tests} PROPERTIES TIMEOUT 3600)
  endif()
endif()
