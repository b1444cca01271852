# OpenImageIO as a plain library. Debian's OpenImageIOConfig.cmake names the command-line tools
# and OpenCV's headers as parts of its targets, which would drag in packages polyrad never uses;
# polyrad needs only the library and its headers.
find_path(POLYRAD_OIIO_INCLUDE_DIR OpenImageIO/imageio.h REQUIRED)
find_library(POLYRAD_OIIO_LIBRARY OpenImageIO REQUIRED)
find_library(POLYRAD_OIIO_UTIL_LIBRARY OpenImageIO_Util REQUIRED)
add_library(polyrad_oiio INTERFACE)
target_include_directories(polyrad_oiio SYSTEM INTERFACE ${POLYRAD_OIIO_INCLUDE_DIR})
target_link_libraries(polyrad_oiio INTERFACE ${POLYRAD_OIIO_LIBRARY} ${POLYRAD_OIIO_UTIL_LIBRARY})
