// The compiled parts of Asio and Beast, once for every user of cairn_web (their
// separate-compilation mode, set on cairn_web). Header-only, each TU that includes them
// compiled the same non-template code again (web_server.cpp: 45 s alone, 29 s without).
#include <boost/asio/impl/src.hpp>
#include <boost/beast/src.hpp>
