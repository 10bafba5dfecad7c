#!/usr/bin/env bash
# Writes the seed corpora (fuzz/seeds/TARGET/NAME) from the spec's test vectors and from
# encoder output. The first byte of each decoder seed picks chunk sizes (see src/lib.rs).
set -euo pipefail
cd "$(dirname "$0")"
rm -rf seeds && mkdir -p seeds
seed() { mkdir -p "seeds/$1"; printf "$3" > "seeds/$1/$2"; }
seed float_tuple v1 '\x03\x01\x07\x40( 1.414 , 3.14159, 1.616, 0.0 )'
seed float_tuple v3 '\x00(-0.15,-0.5,0.3,0,-3.14,0)'
seed float_tuple v5 '\x02\x01\x05(1,2)\n(3,4)\n'
seed float_tuple bad '\x01\x03(1,x,3)(4)noise(5e3)'
seed int32 v6 '\x01\x05\x00\x00\x00\x64\x00\x00\x07\xD0\x00\x00\x75\x30\x00\x00\x00\x64\x00\x00\x07\xD0\x00\x00\x75\x30\xff\xff\xff\xff\x00\x00\x00\x01'
seed byte_list v9 '\x00\x64\xC8\x2Cack'
seed line v13 '\x01\x02reply from the server:\r\nsecond\n'
seed delimited crlf '\x01\x01OK,1\r\nNEXT\r\n\r'
seed stx_etx v20 '\x01\x01\x02hi\x03noise\x02\x02ok\x03'
seed var_message v19 '\x01\x03SET POS_Y 2200\nGET POS_X\nSET A x\n'
seed var_reply v16 '\x01\x04POS_X 1234\nPOS_X 077\nPOS 1\n'
seed read_string v11 '\x00noise>hello<>world<'
seed to_str v21 'p[1, 2, 3, 4, 5, 6]'
seed to_str v22 '[True, False, True]'
seed to_str float '2.123456'
seed split_invariance float '\x00\x02\x01(1,2)\n(3)junk(1e3,x)'
seed split_invariance line '\x04\x01\x03abc\r\ndef\nlonger line here\n'
seed split_invariance stx '\x06\x01\x02\x02ab\x03\x02c'
seed split_invariance var '\x07\x01SET A 1\nGET B\n'
seed split_invariance str '\x09\x01<<hi\r<<x\\r'
seed split_invariance value '\x0a\x01p[1,2,x,4,5,6]\r\n[1, 2]\n12345678901\n'
seed api line '\x00\x10\x00\x00\x00\x00\x00\x00\x00\x00\x10\x00\x00\x00ab\ncd\x01\x02'
seed api floats '\x04\x06\x00\x00\x00\x00\x00\x00\x00\x20\x00\x00\x00\x00\x00\x00\x00\x03\x08\x00\x00\x00\x00\x00\x00\x00\x00\x00\x0a\x00\x00\x00\x00\x00\x00\x00(1,2,3)\x01\x02'
# interp: a program, then (after a NUL byte) what the servers send, in chunks whose
# length is each chunk's first byte (see fuzz_targets/interp.rs).
seed interp vision 'def prog():\n  socket_open("10.0.0.5", 5000, "camera")\n  socket_send_line("shoot", "camera")\n  pose = socket_read_ascii_float(6, "camera")\n  if pose[0] == 6:\n    textmsg("x = ", pose[1])\n  end\nend\n\x00\x18(0.4,-0.2,0.3,0,3.14,0)\n'
seed interp threads 'thread t():\n  i = 0\n  while i < 3:\n    i = i + 1\n    sync()\n  end\nend\nh = run t()\nx = [1, [2, 3], p[0, 0, 0.1, 0, 0, 0]]\nx[1][0] = x[0] * 2 + 1\njoin h\nkill h\nenter_critical\ntextmsg(to_str(x))\nexit_critical\n'
seed interp binary 'socket_open("h", 30002, "s")\nwhile True:\n  n = socket_read_binary_integer(3, "s", 0.1)\n  if n[0] > 0 and n[1] != 2 or not False:\n    socket_send_int(n[1], "s")\n  elif n[0] == 0:\n    break\n  else:\n    socket_set_var("X", 1, "s")\n  end\n  sync()\nend\nhalt\n\x00\x0c\x00\x00\x00\x01\x00\x00\x00\x02\x00\x00\x00\x03\x04\x00\x00\x00\x00'
seed interp functions_cr 'def f(a, b=2.5):\n  local y = a / b\n  global z = [y, y %% 3, -y]\n  return z\nend\nx = f(1)\ns = str_cat("a", 1)\r$ 1 "Robot Program"\rtextmsg(s, x)\r# comment\rsleep(0.01)\r'
seed interp doubling 'x = [1]\nwhile True:\n  x = [x, x]\n  sync()\nend\n'
echo "seeds written: $(find seeds -type f | wc -l) files"
