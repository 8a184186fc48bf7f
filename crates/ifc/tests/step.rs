//! The STEP reader: values and string escapes decoded, and every kind of
//! bad input an error naming the file, the line and the entity.

use gigawalk_ifc::step::{decode_string, StepFile, Value};
use gigawalk_ifc::{IfcError, IfcFile, Schema};

fn file(schema: &str, data: &str) -> String {
    format!(
        "ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION((''),'2;1');\nFILE_NAME('t','',(''),(''),'','','');\nFILE_SCHEMA(('{schema}'));\nENDSEC;\nDATA;\n{data}ENDSEC;\nEND-ISO-10303-21;\n"
    )
}

fn parse(text: &str) -> Result<StepFile, IfcError> {
    StepFile::parse(text.as_bytes().to_vec(), "t.ifc")
}

fn error(text: &str) -> String {
    match parse(text) {
        Ok(_) => panic!("parsed: {text}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn values_decode() {
    let step = parse(&file(
        "IFC4",
        "#1=IFCX('a''b',$,*,.T.,12,-3.5,1.E-5,2.5E+3,(#2,(1,2)),IFCLABEL('x'),\"0FF\");\n#2=IFCY();\n",
    ))
    .unwrap();
    let e = step.get(1).unwrap();
    assert_eq!(e.ty, "IFCX");
    assert_eq!(
        e.args,
        vec![
            Value::Str("a'b".into()),
            Value::Null,
            Value::Derived,
            Value::Enum("T".into()),
            Value::Int(12),
            Value::Real(-3.5),
            Value::Real(1e-5),
            Value::Real(2500.0),
            Value::List(vec![
                Value::Ref(2),
                Value::List(vec![Value::Int(1), Value::Int(2)])
            ]),
            Value::Typed("IFCLABEL".into(), Box::new(Value::Str("x".into()))),
            Value::Binary("0FF".into()),
        ]
    );
    assert!(step.get(2).unwrap().args.is_empty());
    assert_eq!(step.ids_of_type("IFCY").collect::<Vec<_>>(), vec![2]);
    assert_eq!(step.line_of(2), 9);
}

#[test]
fn strings_with_semicolons_comments_and_parentheses_index() {
    let step = parse(&file(
        "IFC2X3",
        "/* a comment; with (parens) */\n#1 = IFCX('a;b)(c', /* inline */ 'd');\n#2=IFCY\n(#1);\n",
    ))
    .unwrap();
    assert_eq!(step.schema, Schema::Ifc2x3);
    let e = step.get(1).unwrap();
    assert_eq!(
        e.args,
        vec![Value::Str("a;b)(c".into()), Value::Str("d".into())]
    );
    assert_eq!(step.get(2).unwrap().args, vec![Value::Ref(1)]);
}

#[test]
fn string_escapes_decode_to_utf8() {
    let check =
        |raw: &str, expected: &str| assert_eq!(decode_string(raw.as_bytes()), expected, "{raw}");
    check("plain", "plain");
    check("it''s", "it's");
    check("\\X2\\30D730ED30B830A730AF30C8\\X0\\", "プロジェクト");
    check("a\\X2\\00E9\\X0\\b", "aéb");
    check("\\X4\\0001F600\\X0\\", "😀");
    // A surrogate pair in \X2\.
    check("\\X2\\D83DDE00\\X0\\", "😀");
    check("gr\\X\\FC\\X\\DF", "grüß");
    check("\\S\\D", "Ä");
    check("back\\\\slash", "back\\slash");
    check("\\PA\\x", "x");
}

#[test]
fn schemas_are_recognised() {
    assert_eq!(parse(&file("IFC4", "")).unwrap().schema, Schema::Ifc4);
    assert_eq!(
        parse(&file("IFC4X3_ADD2", "")).unwrap().schema,
        Schema::Ifc4x3
    );
    assert_eq!(
        parse(&file("IFC2X3_TC1", "")).unwrap().schema,
        Schema::Ifc2x3
    );
    let e = error(&file("AP214", ""));
    assert_eq!(
        e,
        "t.ifc: unsupported schema AP214 (expected IFC2X3, IFC4 or IFC4X3)"
    );
}

#[test]
fn an_empty_file_is_an_error() {
    assert_eq!(error(""), "t.ifc: empty file");
    assert_eq!(error(" \n\n"), "t.ifc: empty file");
    assert!(error("hello").contains("not a STEP physical file"));
}

#[test]
fn a_truncated_file_names_the_line() {
    let full = file("IFC4", "#1=IFCX('a');\n#2=IFCY((1.,2.),#1);\n");
    let cut = &full[..full.find("#2=IFCY((1.,").unwrap() + 10];
    let e = error(cut);
    assert!(e.starts_with("t.ifc: line 9: truncated file"), "{e}");
    assert!(e.contains("#2"), "{e}");
    let e = error(&full[..full.find("ENDSEC;\nEND").unwrap()]);
    assert!(e.contains("truncated file: no ENDSEC"), "{e}");
    let e = error(&full[..full.find("'a'").unwrap() + 2]);
    assert!(e.contains("inside a string of #1"), "{e}");
}

#[test]
fn a_broken_record_names_the_entity_and_line() {
    let e = error(&file("IFC4", "#1=IFCX('a');\n#2=IFCY(1,;\n#3=IFCZ();\n"));
    assert!(e.starts_with("t.ifc: line 9: #2: broken record"), "{e}");
    let e = error(&file("IFC4", "#1 IFCX();\n"));
    assert!(e.contains("line 8: #1: broken record: expected '='"), "{e}");
    let e = error(&file("IFC4", "#1=IFCX()\n#2=IFCY();\n"));
    assert!(e.contains("#1: broken record: expected ';'"), "{e}");
    let e = error(&file("IFC4", "#x=IFCX();\n"));
    assert!(e.contains("bad entity id"), "{e}");
    // Syntax inside the arguments is checked when the entity is decoded.
    let step = parse(&file("IFC4", "#1=IFCX(1 2);\n")).unwrap();
    let e = step.get(1).err().unwrap().to_string();
    assert!(e.starts_with("t.ifc: line 8: #1: broken record"), "{e}");
}

#[test]
fn a_dangling_reference_names_both_ends() {
    let e = error(&file("IFC4", "#1=IFCX(#2);\n#3=IFCY((#1,#9));\n"));
    assert_eq!(
        e,
        "t.ifc: line 8: #1 refers to #2, which the file does not define"
    );
    let e = error(&file("IFC4", "#1=IFCX();\n#1=IFCY();\n"));
    assert!(e.contains("#1 is defined twice"), "{e}");
}

#[test]
fn a_file_without_a_project_is_an_error() {
    let text = file("IFC4", "#1=IFCWALL('x',$,$,$,$,$,$,$,$);\n");
    let e = IfcFile::parse(text.into_bytes(), "t.ifc").err().unwrap();
    assert_eq!(e.to_string(), "t.ifc: no IFCPROJECT entity");
}

#[test]
fn sparse_ids_index() {
    let step = parse(&file("IFC4", "#4000000000=IFCX(#7);\n#7=IFCY();\n")).unwrap();
    assert_eq!(step.get(4_000_000_000).unwrap().args, vec![Value::Ref(7)]);
    assert_eq!(step.type_of(7), Some("IFCY"));
    assert_eq!(step.len(), 2);
}
