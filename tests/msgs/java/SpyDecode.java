// Decodes LCM traffic the way lcm-spy does, without its window: the LCM types are found by
// scanning the class path (lcm.spy.LCMTypeDatabase, lcm-spy's own lookup), each message's class
// by the fingerprint in its first 8 bytes, and the message is decoded by that generated class's
// constructor; its public fields are read by reflection, as lcm-spy's ObjectPanel shows them.
// Nothing in here names a slamd type: put slamd_lcm_types.jar on the class path.
//
//   java -cp lcm.jar:slamd_lcm_types.jar:slamd_spy_decode.jar SpyDecode [LCM_URL]
//
// Prints to stdout, one line each, fields separated by tabs:
//   lcmtype <TAB> slamd.odometry_t <TAB> FINGERPRINT      every LCM type found (signed decimal)
//   ready                                                 subscribed to every channel
//   @channel=NAME <TAB> @type=slamd.estimate_t <TAB> utime=... <TAB> values[0]=... ...
// (and LCMTypeDatabase's own "Found N LCM types"). A message's fields follow its @ entries as
// path=value (nested types as a.b, arrays as a[i]); doubles print with Double.toString, which
// reads back to the same double; in strings \, tab and newline are escaped as \\, \t and \n. A
// message of an unknown type prints @type=? and its fingerprint, one that does not decode
// @error=WHY. It only listens; it runs until killed.
import java.io.DataInput;
import java.io.FileDescriptor;
import java.io.FileOutputStream;
import java.io.PrintStream;
import java.lang.reflect.Array;
import java.lang.reflect.Field;
import java.lang.reflect.Modifier;
import lcm.lcm.LCM;
import lcm.lcm.LCMDataInputStream;
import lcm.lcm.LCMSubscriber;
import lcm.spy.LCMTypeDatabase;
import lcm.util.ClassDiscoverer;

public class SpyDecode implements LCMSubscriber {
  private static final PrintStream out = newStdout();
  private final LCMTypeDatabase types = new LCMTypeDatabase();

  private static PrintStream newStdout() {
    try {
      return new PrintStream(new FileOutputStream(FileDescriptor.out), true, "UTF-8");
    } catch (java.io.UnsupportedEncodingException e) {
      throw new RuntimeException(e);
    }
  }

  public static void main(String[] args) throws Exception {
    // The same scan as LCMTypeDatabase's: every class on the class path with an LCM_FINGERPRINT.
    ClassDiscoverer.findClasses(
        new ClassDiscoverer.ClassVisitor() {
          public void classFound(String jar, Class cls) {
            try {
              Field f = cls.getField("LCM_FINGERPRINT");
              out.println("lcmtype\t" + cls.getName() + "\t" + f.getLong(null));
            } catch (NoSuchFieldException | IllegalAccessException e) {
              // not an LCM type
            }
          }
        });
    SpyDecode decoder = new SpyDecode();
    LCM lcm = args.length > 0 ? new LCM(args[0]) : new LCM();
    lcm.subscribeAll(decoder);
    out.println("ready");
    while (true) Thread.sleep(1000);
  }

  @Override
  public synchronized void messageReceived(LCM lcm, String channel, LCMDataInputStream ins) {
    StringBuilder line = new StringBuilder("@channel=").append(escape(channel));
    try {
      // As lcm-spy's subscriber: fingerprint -> class -> class(DataInput).
      long fingerprint = ins.readLong();
      ins.reset();
      Class<?> cls = types.getClassByFingerprint(fingerprint);
      if (cls == null) {
        line.append("\t@type=?\tfingerprint=").append(fingerprint);
      } else {
        Object message = cls.getConstructor(DataInput.class).newInstance(ins);
        line.append("\t@type=").append(cls.getName());
        flatten("", message, line);
      }
    } catch (Exception e) {
      line.append("\t@error=").append(escape(e.toString()));
    }
    out.println(line);
  }

  private static void flatten(String prefix, Object object, StringBuilder line)
      throws IllegalAccessException {
    for (Field f : object.getClass().getFields()) {
      if (Modifier.isStatic(f.getModifiers())) continue;  // constants, LCM_FINGERPRINT
      value(prefix + f.getName(), f.get(object), line);
    }
  }

  private static void value(String path, Object v, StringBuilder line)
      throws IllegalAccessException {
    if (v == null) {
      line.append('\t').append(path).append("=null");
    } else if (v.getClass().isArray()) {
      for (int i = 0; i < Array.getLength(v); ++i) {
        value(path + "[" + i + "]", Array.get(v, i), line);
      }
    } else if (v instanceof String) {
      line.append('\t').append(path).append('=').append(escape((String) v));
    } else if (v instanceof Number || v instanceof Boolean || v instanceof Character) {
      line.append('\t').append(path).append('=').append(v);
    } else {
      flatten(path + ".", v, line);  // a nested LCM type
    }
  }

  private static String escape(String s) {
    return s.replace("\\", "\\\\").replace("\t", "\\t").replace("\n", "\\n");
  }
}
