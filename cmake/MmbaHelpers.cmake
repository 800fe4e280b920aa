# Helpers shared by every target of mmba (after COLMAP's COLMAP_ADD_LIBRARY and kiss-icp's
# cmake/CompilerOptions.cmake).

# Warnings and language level for one target.
function(mmba_set_target_options TARGET)
  target_compile_features(${TARGET} PUBLIC cxx_std_17)
  set_target_properties(${TARGET} PROPERTIES CXX_EXTENSIONS OFF)
  target_compile_options(${TARGET} PRIVATE -Wall -Wextra -Wno-unused-parameter)
  if(MMBA_WERROR)
    target_compile_options(${TARGET} PRIVATE -Werror)
  endif()
endfunction()

# mmba_add_library(NAME mmba_core SRCS a.cc b.cc PUBLIC_LINK ... PRIVATE_LINK ...)
function(mmba_add_library)
  cmake_parse_arguments(ARG "" "NAME" "SRCS;PUBLIC_LINK;PRIVATE_LINK" ${ARGN})
  add_library(${ARG_NAME} STATIC ${ARG_SRCS})
  target_include_directories(${ARG_NAME} PUBLIC ${PROJECT_SOURCE_DIR}/include
                                         PRIVATE ${PROJECT_SOURCE_DIR}/src)
  target_link_libraries(${ARG_NAME} PUBLIC ${ARG_PUBLIC_LINK} PRIVATE ${ARG_PRIVATE_LINK})
  mmba_set_target_options(${ARG_NAME})
endfunction()

# mmba_add_test(NAME module/unit SRCS x_test.cc LINK ...)
# The ctest names are "module/unit.Suite.Case" (gtest_discover_tests with a prefix).
function(mmba_add_test)
  cmake_parse_arguments(ARG "" "NAME" "SRCS;LINK" ${ARGN})
  string(REPLACE "/" "_" target ${ARG_NAME})
  add_executable(${target}_test ${ARG_SRCS})
  target_link_libraries(${target}_test PRIVATE ${ARG_LINK} GTest::gtest GTest::gtest_main)
  target_compile_definitions(${target}_test PRIVATE
      MMBA_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
      MMBA_BINARY_DIR="${PROJECT_BINARY_DIR}")
  mmba_set_target_options(${target}_test)
  gtest_discover_tests(${target}_test TEST_PREFIX "${ARG_NAME}." DISCOVERY_TIMEOUT 60
                       WORKING_DIRECTORY ${PROJECT_SOURCE_DIR})
endfunction()
