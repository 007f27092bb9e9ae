:- module(rtl_ros1,
          [ rtl_ros1_available/0,
            rtl_ros1_schema/2,          % +Schema, -Handle
            rtl_ros1_event/3            % +Handle, +Bytes, -Event
          ]).

/** <module> ROS 1 messages read into event terms in C

The bag replay and the live ROS 1 node (retalisc/robot_io/ros1_terms.py) can hand a message
to the runtime as its serialized ROS 1 bytes instead of as term text: the C helper
`foreign/rtl_ros1.so` (`c/rtl_ros1.c`, built by setup.sh) builds the event term from the
bytes with a *schema* of the message type, the term layout the text conversion of
robot_io/messages.py writes. That skips the Python decoding of the message, the writing of
its text and the parsing of that text (several kilobytes for a tf message).

The helper is optional: without it rtl_ros1_available/0 fails and the driver sends text.
rtl_ros1_event/3 fails for bytes that are not exactly one message of the type, strings
that are not UTF-8 and floats that are not finite; the driver then converts that message
itself, which reports what is wrong or writes the floats as text.
*/

:- use_module(rtl_foreign).

:- dynamic loaded/0.

load_helper :-
    (   rtl_load_foreign(rtl_ros1, rtl_ros1_term/3)
    ->  retractall(loaded),
        assertz(loaded)
    ;   true
    ).

:- load_helper.

%!  rtl_ros1_available is semidet.
%
%   The C helper is loaded.

rtl_ros1_available :-
    loaded.

%!  rtl_ros1_schema(+Schema, -Handle:integer) is det.
%
%   Register a schema (a ground term, see c/rtl_ros1.c) and give the integer that names it
%   in rtl_ros1_event/3. A malformed schema raises a domain error.

rtl_ros1_schema(Schema, Handle) :-
    loaded,
    !,
    must_be(ground, Schema),
    rtl_ros1_register(Schema, Handle).
rtl_ros1_schema(_, _) :-
    existence_error(foreign_library, rtl_ros1).

%!  rtl_ros1_event(+Handle:integer, +Bytes:string, -Event) is semidet.
%
%   Event is the term of the message whose ROS 1 serialization is Bytes (a string of codes
%   0..255), of the type Handle names; fails when the bytes are not one such message.

rtl_ros1_event(Handle, Bytes, Event) :-
    rtl_ros1_term(Handle, Bytes, Event).
